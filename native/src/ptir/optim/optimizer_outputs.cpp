// The optimiser's outputs (OUT/gaussians.ply, env.exr, log.csv, settings.json, and the
// environment's or mesh materials' JSON side files), each written atomically.
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/core/number_text.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/image.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/gaussian_ply.h"

namespace ptir {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

std::string num(double v) { return num_text(v); }

ojson rgb_json(Vec3 v) { return ojson::array({json_number(v.x), json_number(v.y), json_number(v.z)}); }

// OUT/mesh_materials.json: the optimised material of every mesh, by name.
std::string mesh_materials_json(const std::vector<TriangleMesh>& meshes) {
  ojson list = ojson::array();
  for (const TriangleMesh& m : meshes)
    list.push_back(ojson{{"name", m.name},
                         {"base_colour", rgb_json(m.material.base_colour)},
                         {"roughness", json_number(m.material.roughness)},
                         {"metallic", json_number(m.material.metallic)}});
  return ojson{{"meshes", list}}.dump(2) + "\n";
}

// The scene's environment as a lat-long RGB image (black 1x1 without one).
Image latlong_image(const Scene& scene, const ParameterSettings& ps) {
  if (!scene.environment.present()) return Image(1, 1, {"R", "G", "B"});
  return scene.environment->to_latlong(ps.env_width, ps.env_height);
}

}  // namespace

std::string Optimizer::log_csv() const {
  std::ostringstream s;
  s << "iteration,loss,image,tv,prior,prior_weight,seconds,primal_s,backward_s,regulariser_s,update_s,cpu_s,primal_cpu_s,"
       "backward_cpu_s,views\n";
  for (const IterationLog& l : log_) {
    s << l.iteration << ',' << num(l.loss) << ',' << num(l.image) << ',' << num(l.tv) << ',' << num(l.prior) << ','
      << num(l.prior_weight) << ',' << num(l.seconds) << ',' << num(l.primal_s) << ',' << num(l.backward_s) << ','
      << num(l.regulariser_s) << ',' << num(l.update_s) << ',' << num(l.cpu_s) << ',' << num(l.primal_cpu_s) << ','
      << num(l.backward_cpu_s) << ',' << l.views << '\n';
  }
  return s.str();
}

Image Optimizer::environment_image() const { return latlong_image(*scene_, settings_.params); }

void Optimizer::write_outputs(const std::string& dir) const {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir, "cannot create the output folder");
  const fs::path out(dir);
  const Scene* scene = scene_.get();
  const Parameters& result = params_;
  save_gaussians((out / "gaussians.ply").string(), *scene->gaussians);
  write_image((out / "env.exr").string(), latlong_image(*scene, settings_.params), Encoding::Colour);
  io::write_text_atomic((out / "log.csv").string(), log_csv());
  // Models whose parameters the lat-long image does not carry exactly (SGs) add env_<type>.json.
  ojson env_params;
  if (scene->environment.present() && scene->environment->parameters_json(&env_params))
    io::write_text_atomic((out / ("env_" + std::string(scene->environment->type()) + ".json")).string(),
                          env_params.dump(2) + "\n");
  if (const ParameterGroup* e = result.find(ParamKind::Exposure)) {  // --learn-exposure: view name -> scale
    ojson ex = ojson::object();
    for (size_t v = 0; v < e->raw.size(); ++v) ex[dataset_->views[v].camera.name] = std::exp(double(e->raw[v]));
    io::write_text_atomic((out / "exposure.json").string(), ex.dump(1) + "\n");
  }
  if (const ParameterGroup* b = result.find(ParamKind::LightBalance)) {  // light_balance.h: the albedos' total move
    ojson lb = {{"albedo_scale", {std::exp(double(b->raw[0])), std::exp(double(b->raw[1])), std::exp(double(b->raw[2]))}}};
    io::write_text_atomic((out / "light_balance.json").string(), lb.dump(1) + "\n");
  }
  if (result.find(ParamKind::MeshColour))
    io::write_text_atomic((out / "mesh_materials.json").string(), mesh_materials_json(scene->meshes));
  // OUT/settings.json: what the run resolved (the checkpoint's fingerprint, the dataset's
  // layout, the pixel filter, the iterations), so runs on the same data in two layouts can
  // be compared setting by setting (issue 38: docs/captures.md).
  ojson rec = ojson::object();
  rec["layout"] = dataset_->layout;
  rec["iterations"] = settings_.iterations;
  rec["pixel_filter"] =
      std::string(pixel_filter_name(settings_.integrator.filter.type)) + " " + num(settings_.integrator.filter.width);
  for (const auto& kv : fingerprint()) rec[kv.first] = kv.second;
  // A real capture's analysis (scene/capture_calibration.h): subject, EXIF, colours, geometry kept.
  if (!dataset_->calibration_record.empty()) rec["capture"] = ojson::parse(dataset_->calibration_record);
  // The known map's alignment (env_align.h): yaw, scale, every candidate's score.
  if (env_align_.mode != EnvAlignMode::Off) rec["env_align"] = ojson::parse(env_align_.json());
  io::write_text_atomic((out / "settings.json").string(), rec.dump(1) + "\n");
}

}  // namespace ptir
