#include "ptir/pipeline/capture_stage.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/io/image.h"
#include "ptir/lights/env_detail.h"
#include "ptir/scene/capture_calibration.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"

namespace ptir::pipeline {

namespace fs = std::filesystem;

CaptureStageResult run_capture_stage(const CaptureStage& c) {
  CaptureStageResult r;
  DatasetOptions dopt;
  apply_capture_options(c.capture, dopt);
  if (!dopt.calibration.empty()) return r;  // given: applied as it is
  const std::string layout = dopt.layout == "auto" ? detect_layout(c.dataset) : dopt.layout;
  if (layout == "nerf" || layout.empty()) return r;
  const fs::path dir = fs::path(c.out) / "capture";
  const fs::path cal = dir / "calibration.json", env = dir / "background_env.exr";
  std::error_code ec;
  if (c.resume && fs::exists(cal, ec)) {
    r.calibration = cal.string();
    if (fs::exists(env, ec)) r.background_env = env.string();
    return r;
  }
  dopt.split = "all";
  const std::unique_ptr<Dataset> all = load_dataset(c.dataset, dopt);
  if (!c.quiet && !all->size_note.empty()) std::fprintf(stderr, "capture: %s\n", all->size_note.c_str());
  // A capture with its own masks was prepared by its user (or converted from a masked set): it is
  // read as it is, as the same set in the NeRF layout would be (docs/captures.md, issue 38).
  for (const DatasetView& v : all->views)
    if (!v.files.mask.empty()) {
      if (!c.quiet) std::fprintf(stderr, "capture: its own masks are used, its photos as they are\n");
      return r;
    }
  // Progress: about every 5 % of the photos (each is rendered from the splat once).
  const auto start = std::chrono::steady_clock::now();
  const ProgressPrinter progress = c.progress.quiet(c.quiet);
  auto on_photo = [&](size_t done, size_t total) {
    const size_t step = std::max<size_t>(1, total / 20);
    if (done % step != 0 && done != total) return;
    progress.capture_photo(int(done), int(total),
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  };
  CaptureAnalysis a = analyse_capture(load_gaussians(c.gaussians), *all, c.s, on_photo);
  if (!c.quiet)
    for (const std::string& line : capture_analysis_lines(a)) std::fprintf(stderr, "%s\n", line.c_str());
  c.progress.quiet(c.quiet).subject(a.subject, a.median_covered);
  fs::remove_all(dir, ec);
  write_capture_analysis(a, *all, c.s, dir.string());
  r.calibration = cal.string();
  if (a.background.width > 0) r.background_env = env.string();
  return r;
}

bool fit_kept_input(const std::string& fit_dir) {
  const fs::path check = fs::path(fit_dir) / "check.json";
  std::error_code ec;
  if (!fs::exists(check, ec)) return false;
  std::ifstream in(check);
  try {
    return nlohmann::json::parse(in).value("kept", std::string()) == "input";
  } catch (const std::exception& e) {
    throw Error(check.string(), std::string("not valid JSON: ") + e.what());
  }
}

void write_env_with_detail(const std::string& out) {
  const fs::path dir = fs::path(out) / "capture";
  const fs::path start = dir / "background_env.exr", seen = dir / "background_seen.exr", env = fs::path(out) / "env.exr";
  std::error_code ec;
  if (!fs::exists(start, ec) || !fs::exists(seen, ec) || !fs::exists(env, ec)) return;
  const Image learnt = read_image(env.string());
  write_image(env.string(), env_with_detail(learnt, read_image(seen.string())));
}

}  // namespace ptir::pipeline
