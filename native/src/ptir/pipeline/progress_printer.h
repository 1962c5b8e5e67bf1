// The pipeline's progress, in one place: each stage reports its events here and
// the printer writes them on stderr, as the text lines `ptir optimize` and `ptir
// fit` have always printed (--progress text, the default) or as one JSON object
// per line (--progress json; docs/engine_protocol.md, "Progress lines"), and hands
// each event to a callback (the Python module's progress_callback).
//
// The JSON events (every object has "event"; numbers as numbers, NaN as null; written
// compact, without the spaces shown here):
//   {"event": "subject", "subject": "object"|"scene", "covered": 0.42}       a real capture's analysis
//   {"event": "target", "stage": "radiance", "view": 3, "total": 24, "elapsed_s": 1.2}
//   {"event": "target", "stage": "capture", "view": 3, "total": 84, "elapsed_s": 1.2}   a capture's photos measured
//   {"event": "estimate", "s_per_iter": 0.8, "iterations": 400, "eta_s": 320.0, "eta": "5m20s"}
//   {"event": "iteration", "stage": "optimize"|"fit", "iteration": 5, "total": 400, "loss": 0.01,
//    "s_per_iter": 0.8, "eta_s": 316.0, "eta": "5m16s", ...the stage's loss terms}
//   {"event": "done", "stage": ..., "status": "finished"|"cancelled", "iterations": 400, "out": "OUT"}
//   {"event": "error", "message": "..."}
// Text lines other than these (notes, the set-up's summary, "wrote ...") stay text
// in both forms: they are the log, not the progress.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "ptir/optim/checkpoint.h"
#include "ptir/optim/geometry_fit.h"

namespace ptir::pipeline {

enum class ProgressFormat { text, json };

// "text" or "json"; throws Error naming --progress otherwise.
ProgressFormat parse_progress_format(const std::string& name);

// Receives every event; returning false asks the run to stop (as Ctrl-C does).
using ProgressCallback = std::function<bool(const nlohmann::ordered_json& event)>;

class ProgressPrinter {
 public:
  ProgressPrinter() = default;
  ProgressPrinter(ProgressFormat format, bool quiet, ProgressCallback callback = {})
      : format_(format), quiet_(quiet), callback_(std::move(callback)) {}

  // The same printer, silent (a rank other than 0, a stage run quietly); the callback stays.
  ProgressPrinter quiet(bool q = true) const { return ProgressPrinter(format_, quiet_ || q, callback_); }
  bool is_quiet() const { return quiet_; }
  ProgressFormat format() const { return format_; }

  void subject(const std::string& subject, double covered) const;
  void radiance_target(int done, int total, double elapsed_s) const;
  void capture_photo(int done, int total, double elapsed_s) const;
  void estimate(double s_per_iter, int iterations, const std::string& text_line) const;
  void optimize_iteration(const IterationLog& l, int total, double eta_s) const;
  void fit_iteration(const FitLog& l, int total, double eta_s) const;
  void done(const char* stage, bool finished, int iterations, const std::string& out) const;
  void error(const std::string& message) const;

 private:
  // Hands the event to the callback and prints it (JSON) or `text` (text form, unless empty).
  void emit(const nlohmann::ordered_json& event, const std::string& text) const;

  ProgressFormat format_ = ProgressFormat::text;
  bool quiet_ = false;
  ProgressCallback callback_;
};

}  // namespace ptir::pipeline
