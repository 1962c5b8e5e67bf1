#include "ptir/pipeline/output_guard.h"

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/scene/json_limits.h"

namespace fs = std::filesystem;

namespace ptir::pipeline {

namespace {

bool same_entry(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  return fs::equivalent(a, b, ec) && !ec;
}

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// The folder a relative file name is in ("." for a bare name).
fs::path folder_of(const fs::path& file) { return file.has_parent_path() ? file.parent_path() : fs::path("."); }

// Every string in a scene file that names an existing file (relative names are
// taken beside the scene, as the scene loader does).
void collect_named_files(const nlohmann::json& j, const fs::path& base, std::vector<std::string>& out) {
  if (j.is_string()) {
    const std::string s = j.get<std::string>();
    if (s.empty() || s.size() > 4096) return;
    const fs::path p(s);
    const fs::path candidate = p.is_absolute() ? p : base / p;
    if (is_file(candidate)) out.push_back(candidate.string());
  } else if (j.is_structured()) {
    for (const auto& item : j) collect_named_files(item, base, out);
  }
}

// The input files given directly, and the files their scene files name.
void input_files(const Inputs& in, std::vector<std::string>& direct, std::vector<std::string>& named) {
  for (const std::string& f : in.files)
    if (!f.empty() && is_file(f)) direct.push_back(f);
  for (const std::string& s : in.scenes) {
    if (s.empty() || !is_file(s)) continue;
    direct.push_back(s);
    nlohmann::json j;
    try {
      j = load_json_file(s, "scene file");  // bounded (depth, size, regular file): the recursion below is too
    } catch (const Error&) {
      continue;  // the scene loader reports it, naming the file
    }
    collect_named_files(j, folder_of(s), named);
  }
}

fs::path canonical_of(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? fs::path() : c;
}

// Whether `p` is `dir` or lies inside it (both canonical).
bool inside(const fs::path& p, const fs::path& dir) {
  if (p.empty() || dir.empty()) return false;
  auto pi = p.begin();
  for (auto di = dir.begin(); di != dir.end(); ++di, ++pi) {
    if (di->empty() && std::next(di) == dir.end()) break;  // a trailing separator
    if (pi == p.end() || *pi != *di) return false;
  }
  return true;
}

fs::path nearest_existing(fs::path p) {
  std::error_code ec;
  while (!p.empty() && !fs::exists(p, ec) && p.has_parent_path() && p.parent_path() != p) p = p.parent_path();
  return p;
}

// A result folder of ours inside a dataset: writing there is fine. One that optimize
// or fit wrote (its checkpoint or log), or a result eval reads (gaussians.ply beside
// env.exr: the dataset maker's oracle/, whose eval/ goes into it).
bool is_result_folder(const fs::path& dir, const fs::path& root) {
  std::error_code ec;
  for (fs::path d = dir; inside(d, root) && d != root; d = d.parent_path()) {
    if (fs::exists(d / "checkpoint.bin", ec) || fs::exists(d / "log.csv", ec)) return true;
    if (fs::is_regular_file(d / "gaussians.ply", ec) && fs::is_regular_file(d / "env.exr", ec)) return true;
  }
  return false;
}

// The dataset rule (output_guard.h): `out` (a file, or a folder when `folder`)
// lands in one of the dataset's own folders. A new folder directly in the
// dataset (DATASET/result) and result folders of ours are fine.
bool lands_in_dataset(const std::string& out, bool folder, const fs::path& root) {
  const fs::path o = canonical_of(out);
  if (o.empty() || !inside(o, root)) return false;
  const fs::path where = folder ? o : o.parent_path();
  const fs::path existing = nearest_existing(where);
  if (folder && existing == root && where != root && where.parent_path() == root) return false;  // DATASET/new
  return !is_result_folder(existing, root);
}

// A result folder of ours at `dir` (anything optimize, fit or eval wrote: their
// checkpoint, log, plan, budget, metrics; or a result eval reads).
bool is_our_result(const fs::path& dir) {
  std::error_code ec;
  for (const char* name : {"checkpoint.bin", "log.csv", "settings.json", "budget.json", "views.json", "metrics.json"})
    if (fs::exists(dir / name, ec)) return true;
  return fs::is_regular_file(dir / "gaussians.ply", ec) && fs::is_regular_file(dir / "env.exr", ec);
}

// What makes `dir` a dataset (photos or poses of someone's capture), or "" when nothing does.
std::string dataset_marker(const fs::path& dir) {
  std::error_code ec;
  for (const char* sub : {"images", "sparse"})
    if (fs::is_directory(dir / sub, ec)) return std::string(sub) + "/";
  if (fs::is_regular_file(dir / "cameras.json", ec) && fs::exists(dir / "cfg_args", ec)) return "cameras.json and cfg_args";
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::string ext = it->path().extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (name.rfind("transforms", 0) == 0 && ext == ".json") return name;
    if (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".dng")
      return "photos (" + name + ")";
  }
  return "";
}

[[noreturn]] void refuse(const std::string& output, const std::string& why) {
  throw Error(output, why + "; refusing to overwrite inputs (choose another output, or pass --force)");
}

}  // namespace

void guard_outputs(const Inputs& inputs, const Outputs& outputs, bool force) {
  if (force) return;
  std::vector<std::string> direct, named;
  input_files(inputs, direct, named);
  for (const std::string& data : inputs.datasets) {
    const fs::path root = data.empty() ? fs::path() : canonical_of(data);
    if (root.empty()) continue;
    for (const std::string& out : outputs.files)
      if (!out.empty() && lands_in_dataset(out, false, root))
        refuse(out, "is inside the dataset " + data + " (nothing is written among a dataset's files)");
    for (const std::string& out : outputs.folders)
      if (!out.empty() && lands_in_dataset(out, true, root))
        refuse(out, "is inside the dataset " + data + " (nothing is written among a dataset's files)");
  }
  for (const std::string& out : outputs.files) {
    if (out.empty()) continue;
    for (const std::vector<std::string>* list : {&direct, &named})
      for (const std::string& in : *list)
        if (same_entry(out, in)) refuse(out, "is an input file (" + in + ")");
  }
  for (const std::string& dir : outputs.folders) {
    if (dir.empty()) continue;
    for (const std::string& in : inputs.folders)
      if (!in.empty() && same_entry(dir, in))
        refuse(dir, "is the input folder " + in + " (outputs would be written among the inputs)");
    for (const std::string& in : direct)
      if (same_entry(dir, folder_of(in)))
        refuse(dir, "holds the input file " + in + " (outputs would be written beside and over the inputs)");
  }
}

void guard_result_folder(const std::string& dir, bool force) {
  std::error_code ec;
  if (force || dir.empty() || !fs::is_directory(dir, ec) || is_our_result(dir)) return;
  const std::string marker = dataset_marker(dir);
  if (!marker.empty())
    refuse(dir, "holds a dataset's files (" + marker + "), not a result of ours: the result (gaussians.ply, "
                "checkpoints) would be written among them");
}

std::unique_ptr<io::OutputLock> lock_output_folder(const std::string& dir, const std::string& command) {
  return std::make_unique<io::OutputLock>(dir, command);
}

void remove_stale_outputs(const std::vector<std::string>& folders, bool quiet, bool with_subfolders) {
  for (const std::string& dir : folders) {
    if (dir.empty()) continue;
    size_t removed = io::remove_stale_temps(dir);
    if (with_subfolders) {
      std::error_code ec;
      for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
        if (it->is_directory(ec)) removed += io::remove_stale_temps(it->path());
    }
    if (removed > 0 && !quiet)
      std::fprintf(stderr, "removed %zu unfinished temporary file(s) left in %s by an interrupted run\n", removed, dir.c_str());
  }
}

}  // namespace ptir::pipeline
