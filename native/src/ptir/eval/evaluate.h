// `ptir eval`: the evaluation protocol of docs/method.md §7 on a dataset's test views.
//
// For every test view i it renders, with the recovered asset (RESULT/gaussians.ply
// under RESULT/env.exr):
//   OUT/eval/test_XXX/rgba.exr                       novel view (path traced, transparent film:
//                                                    premultiplied RGB, A = coverage)
//   OUT/eval/test_XXX/albedo.exr, roughness.exr, metallic.exr, normal.exr
//                                                    primary-hit AOVs (straight values, A = coverage,
//                                                    like `ptir render --aov`), before any scaling
//   OUT/eval/test_XXX/rgba_<NAME>.exr                relit under each --relight environment with
//                                                    the albedo scaled by the albedo scale
// and, where the dataset has the ground truth:
//   albedo PSNR   s_c = median over foreground pixels of ALL test views of gt_c / pred_c
//                 (linear); PSNR of clamp(s pred) against gt over the foreground pixels
//                 of each view, in sRGB display values (the PNG values the peers compare;
//                 albedo_psnr_linear has the same in linear values); mean over views
//   NVS PSNR/SSIM rgba.exr vs rgba.png, both as sRGB display values composited over
//                 white by their own alpha, whole image (TensoIR's protocol); mean over views
//   relight PSNR/SSIM  the same for rgba_<NAME>.exr vs rgba_<NAME>.png (no extra scale fit)
//   roughness MSE whole image, background (gt alpha <= 0.5) zeroed in both; mean over views
//   normal MAE    mean angle (degrees) over foreground pixels; mean over views
// Foreground: the test image's alpha > 0.5.
//
// Writes OUT/eval/metrics.json, OUT/eval/metrics.md (a markdown table) and
// contact sheets OUT/eval/sheet_<quantity>.png (rows = views, columns = ground
// truth | ours | error heat map; see metrics.md for the error scales); views without
// material ground truth (photos) get sheet_materials.png instead: photo | albedo |
// roughness | normal, what was recovered beside what was photographed.
//
// The folder is written whole: into RESULT/.eval-staging, which replaces
// RESULT/eval only once metrics.json is in it (io/atomic_folder.h), so a failure
// (a full disk, an unreadable ground truth, a kill) leaves the previous
// evaluation as it was, never new renders beside old metrics.
//
// Data-parallel runs (`mpirun -np N ptir eval`; EvalSettings::comm): every render
// is dealt to the ranks in row bands and gathered (render/row_bands.h); rank 0
// alone writes and scores, and returns the report (the other ranks return an
// empty one).
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ptir/core/communicator.h"
#include "ptir/core/render_control.h"
#include "ptir/material/shading_model.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/scene/dataset.h"

namespace ptir::eval {

// Where an evaluation is written before it replaces RESULT/eval.
constexpr const char* kEvalStaging = ".eval-staging";

struct RelightEnv {
  std::string name;  // rgba_<name>.png / rgba_<name>.exr
  std::string path;  // lat-long EXR/HDR, Blender orientation, strength 1
};

struct EvalSettings {
  std::string dataset;            // dataset folder (TensoIR / NeRF-synthetic layout)
  std::string result;             // folder with gaussians.ply and env.exr
  std::string split = "test";
  DatasetOptions dataset_options; // how to read the dataset (layout, images folder, hold-out; split is set from above)
  std::string scene;              // optional scene file: its meshes and lights are added
  std::vector<RelightEnv> relight;
  int spp = 64;                   // path-traced renders
  int bounces = 4;                // indirect bounces (the dataset maker's Cycles limit)
  int aov_spp = 16;               // jittered AOV samples (GT passes are pixel averages)
  uint64_t seed = 0;
  std::optional<BsdfModel> brdf;  // surface model (unset: the scene file's, else the dataset's "ptir_brdf", else principled-v2)
  // Pixel filter; what is unset comes from the dataset (dataset.json), else Blender's default.
  std::optional<PixelFilterType> filter_type;
  std::optional<float> filter_width;
  int sheet_views = 8;            // contact sheets show the first N views (0: no sheets)
  std::function<void(const std::string&)> log;  // progress lines (optional)
  RenderControl control;          // cancel / progress of each render
  const Communicator* comm = &single_process();  // data-parallel runs (must outlive evaluate)
};

struct EvalReport {
  nlohmann::json metrics;  // what metrics.json holds
  std::string markdown;    // what metrics.md holds
  std::string out_dir;     // RESULT/eval
};

// Runs the evaluation and writes the files listed above. Throws ptir::Error
// naming the file at fault (missing result files, unreadable ground truth).
EvalReport evaluate(const EvalSettings& settings);

// "NAME=path" -> RelightEnv; throws Error for a malformed spec.
RelightEnv parse_relight(const std::string& spec);

// The markdown table of a metrics JSON (also used by the CLI to print it).
std::string metrics_markdown(const nlohmann::json& metrics);

}  // namespace ptir::eval
