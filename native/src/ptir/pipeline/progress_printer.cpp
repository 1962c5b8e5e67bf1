#include "ptir/pipeline/progress_printer.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/pipeline/run_control.h"

namespace ptir::pipeline {

using ojson = nlohmann::ordered_json;

ProgressFormat parse_progress_format(const std::string& name) {
  if (name == "text") return ProgressFormat::text;
  if (name == "json") return ProgressFormat::json;
  throw Error("--progress must be text or json, got '" + name + "'");
}

namespace {

// A number for the JSON line; NaN and infinities as null (JSON has none).
ojson number(double v) { return std::isfinite(v) ? ojson(v) : ojson(nullptr); }

std::string printf_text(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string printf_text(const char* fmt, ...) {
  va_list args, again;
  va_start(args, fmt);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  va_end(args);
  std::vector<char> buf(size_t(std::max(n, 0)) + 1);
  std::vsnprintf(buf.data(), buf.size(), fmt, again);
  va_end(again);
  return buf.data();
}

}  // namespace

void ProgressPrinter::emit(const ojson& event, const std::string& text) const {
  if (callback_ && !callback_(event)) g_interrupted.store(true);  // stops where Ctrl-C would
  if (quiet_) return;
  if (format_ == ProgressFormat::json) {
    std::fprintf(stderr, "%s\n", event.dump(-1, ' ', false, ojson::error_handler_t::replace).c_str());
    std::fflush(stderr);
  } else if (!text.empty()) {
    std::fputs(text.c_str(), stderr);
  }
}

void ProgressPrinter::subject(const std::string& subject, double covered) const {
  emit({{"event", "subject"}, {"subject", subject}, {"covered", number(covered)}}, "");
}

void ProgressPrinter::radiance_target(int done, int total, double elapsed_s) const {
  emit({{"event", "target"}, {"stage", "radiance"}, {"view", done}, {"total", total}, {"elapsed_s", number(elapsed_s)}},
       printf_text("radiance: view %d/%d rendered  %s elapsed\n", done, total, duration_text(elapsed_s).c_str()));
}

void ProgressPrinter::capture_photo(int done, int total, double elapsed_s) const {
  emit({{"event", "target"}, {"stage", "capture"}, {"view", done}, {"total", total}, {"elapsed_s", number(elapsed_s)}},
       printf_text("capture: photo %d/%d measured against the splat  %s elapsed\n", done, total,
                   duration_text(elapsed_s).c_str()));
}

void ProgressPrinter::estimate(double s_per_iter, int iterations, const std::string& text_line) const {
  const double eta = s_per_iter * iterations;
  emit({{"event", "estimate"}, {"s_per_iter", number(s_per_iter)}, {"iterations", iterations}, {"eta_s", number(eta)},
        {"eta", duration_text(eta)}},
       text_line);
}

void ProgressPrinter::optimize_iteration(const IterationLog& l, int total, double eta_s) const {
  emit({{"event", "iteration"}, {"stage", "optimize"}, {"iteration", l.iteration}, {"total", total},
        {"loss", number(l.loss)}, {"image", number(l.image)}, {"tv", number(l.tv)}, {"prior", number(l.prior)},
        {"s_per_iter", number(l.seconds)}, {"eta_s", number(eta_s)}, {"eta", duration_text(eta_s)}, {"views", l.views}},
       printf_text("iter %d/%d  loss %.5f (image %.5f tv %.5f prior %.5f)  %.2f s/iter  ETA %s  [%s]\n", l.iteration, total,
              l.loss, l.image, l.tv, l.prior, l.seconds, duration_text(eta_s).c_str(), l.views.c_str()));
}

void ProgressPrinter::fit_iteration(const FitLog& l, int total, double eta_s) const {
  std::string text = printf_text("iter %d/%d  loss %.5f (image %.5f mask %.5f normal %.5f)  %zu Gaussians", l.iteration,
                            total, l.loss, l.image, l.mask, l.normal, l.gaussians);
  if (l.pruned || l.cloned || l.split) text += printf_text(" (-%d +%d clones +%d splits)", l.pruned, l.cloned, l.split);
  if (l.flipped) text += printf_text(" (%d normals re-oriented)", l.flipped);
  text += printf_text("  %.2f s/iter  ETA %s\n", l.seconds, duration_text(eta_s).c_str());
  emit({{"event", "iteration"}, {"stage", "fit"}, {"iteration", l.iteration}, {"total", total}, {"loss", number(l.loss)},
        {"image", number(l.image)}, {"mask", number(l.mask)}, {"normal", number(l.normal)}, {"gaussians", l.gaussians},
        {"pruned", l.pruned}, {"cloned", l.cloned}, {"split", l.split}, {"flipped", l.flipped},
        {"s_per_iter", number(l.seconds)}, {"eta_s", number(eta_s)}, {"eta", duration_text(eta_s)}},
       text);
}

void ProgressPrinter::done(const char* stage, bool finished, int iterations, const std::string& out) const {
  emit({{"event", "done"}, {"stage", stage}, {"status", finished ? "finished" : "cancelled"}, {"iterations", iterations},
        {"out", out}},
       "");
}

void ProgressPrinter::error(const std::string& message) const {
  emit({{"event", "error"}, {"message", message}}, "");
}

}  // namespace ptir::pipeline
