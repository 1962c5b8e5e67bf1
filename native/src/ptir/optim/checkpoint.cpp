#include "ptir/optim/checkpoint.h"

#include <cstring>
#include <fstream>
#include <sstream>

#include "ptir/core/fnv1a.h"
#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"

namespace ptir {


namespace {

constexpr char kMagic[8] = {'P', 'T', 'I', 'R', 'C', 'K', 'P', 'T'};
constexpr uint32_t kVersion = 2;  // 2 added the iterate average; 1 is still read
// The SG environment's group kind before every environment model became one group.
constexpr uint32_t kEnvSgBeforeOneGroup = 4;


struct Writer {
  std::string buf;
  template <class T>
  void pod(const T& v) {
    buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void str(const std::string& s) {
    pod(uint64_t(s.size()));
    buf += s;
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    pod(uint64_t(v.size()));
    buf.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
};

struct Reader {
  const std::string& buf;
  const std::string& path;
  size_t pos = 0;
  void need(size_t n) {
    if (n > buf.size() - pos) throw Error(path, "checkpoint is truncated or corrupt");
  }
  template <class T>
  T pod() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, buf.data() + pos, sizeof(T));
    pos += sizeof(T);
    return v;
  }
  std::string str() {
    uint64_t n = pod<uint64_t>();
    need(n);
    std::string s = buf.substr(pos, n);
    pos += n;
    return s;
  }
  template <class T>
  std::vector<T> vec() {
    uint64_t n = pod<uint64_t>();
    if (n > (buf.size() - pos) / sizeof(T)) throw Error(path, "checkpoint is truncated or corrupt");
    std::vector<T> v(n);
    std::memcpy(v.data(), buf.data() + pos, n * sizeof(T));
    pos += n * sizeof(T);
    return v;
  }
};

}  // namespace

void write_checkpoint(const std::string& path, const Checkpoint& c) {
  Writer w;
  w.buf.append(kMagic, 8);
  w.pod(kVersion);
  w.pod(c.iteration);
  w.pod(uint64_t(c.fingerprint.size()));
  for (const auto& kv : c.fingerprint) {
    w.str(kv.first);
    w.str(kv.second);
  }
  w.pod(uint64_t(c.groups.size()));
  for (const CheckpointGroup& g : c.groups) {
    w.pod(uint32_t(g.kind));
    w.pod(g.lr);
    w.pod(g.adam_t);
    w.vec(g.raw);
    w.vec(g.m);
    w.vec(g.v);
  }
  w.vec(c.normals);
  w.pod(uint64_t(c.log.size()));
  for (const IterationLog& l : c.log) {
    w.pod(int32_t(l.iteration));
    for (double d : {l.loss, l.image, l.tv, l.prior, l.prior_weight, l.seconds, l.primal_s, l.backward_s, l.regulariser_s,
                     l.update_s, l.cpu_s, l.primal_cpu_s, l.backward_cpu_s})
      w.pod(d);
    w.str(l.views);
  }
  w.pod(c.averaged);
  w.pod(c.average_begin);
  w.pod(uint64_t(c.average_sum.size()));
  for (const auto& a : c.average_sum) w.vec(a);
  w.pod(fnv1a(w.buf));
  io::write_bytes_atomic(path, w.buf.data(), w.buf.size());
}

Checkpoint read_checkpoint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open checkpoint");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string buf = ss.str();
  if (buf.size() < 8 + 4 + 8 || std::memcmp(buf.data(), kMagic, 8) != 0) throw Error(path, "not a PTIR checkpoint");
  uint64_t stored;
  std::memcpy(&stored, buf.data() + buf.size() - 8, 8);
  const std::string body = buf.substr(0, buf.size() - 8);
  if (fnv1a(body) != stored) throw Error(path, "checkpoint is truncated or corrupt (checksum mismatch)");
  Reader r{body, path, 8};
  uint32_t version = r.pod<uint32_t>();
  if (version != kVersion && version != 1)
    throw Error(path, "checkpoint version " + std::to_string(version) + " (this build reads " + std::to_string(kVersion) + ")");
  Checkpoint c;
  c.iteration = r.pod<uint64_t>();
  uint64_t nf = r.pod<uint64_t>();
  for (uint64_t i = 0; i < nf; ++i) {
    std::string k = r.str();
    c.fingerprint.emplace_back(k, r.str());
  }
  uint64_t ng = r.pod<uint64_t>();
  for (uint64_t i = 0; i < ng; ++i) {
    CheckpointGroup g;
    uint32_t kind = r.pod<uint32_t>();
    if (kind > uint32_t(ParamKind::LastKind)) throw Error(path, "checkpoint has an unknown parameter group");
    if (kind == kEnvSgBeforeOneGroup) kind = uint32_t(ParamKind::Environment);
    g.kind = ParamKind(kind);
    g.lr = r.pod<float>();
    g.adam_t = r.pod<uint64_t>();
    g.raw = r.vec<float>();
    g.m = r.vec<float>();
    g.v = r.vec<float>();
    if (g.m.size() != g.raw.size() || g.v.size() != g.raw.size()) throw Error(path, "checkpoint is corrupt (group sizes)");
    c.groups.push_back(std::move(g));
  }
  c.normals = r.vec<Vec3>();
  uint64_t nl = r.pod<uint64_t>();
  for (uint64_t i = 0; i < nl; ++i) {
    IterationLog l;
    l.iteration = r.pod<int32_t>();
    for (double* d : {&l.loss, &l.image, &l.tv, &l.prior, &l.prior_weight, &l.seconds, &l.primal_s, &l.backward_s,
                      &l.regulariser_s, &l.update_s, &l.cpu_s, &l.primal_cpu_s, &l.backward_cpu_s})
      *d = r.pod<double>();
    l.views = r.str();
    c.log.push_back(std::move(l));
  }
  if (version >= 2) {
    c.averaged = r.pod<uint64_t>();
    c.average_begin = r.pod<int64_t>();
    const uint64_t na = r.pod<uint64_t>();
    if (na > ng) throw Error(path, "checkpoint is corrupt (average groups)");
    for (uint64_t i = 0; i < na; ++i) {
      c.average_sum.push_back(r.vec<double>());
      if (c.average_sum.back().size() != c.groups[i].raw.size()) throw Error(path, "checkpoint is corrupt (average sizes)");
    }
  }
  if (r.pos != body.size()) throw Error(path, "checkpoint is corrupt (trailing data)");
  return c;
}

void check_fingerprint(const std::string& path, const Fingerprint& stored, const Fingerprint& current) {
  std::string diff;
  for (const auto& kv : current) {
    const std::string* old = nullptr;
    for (const auto& s : stored)
      if (s.first == kv.first) old = &s.second;
    if (!old) diff += "\n  " + kv.first + ": not in the checkpoint (now " + kv.second + ")";
    else if (*old != kv.second) diff += "\n  " + kv.first + ": checkpoint " + *old + ", now " + kv.second;
  }
  for (const auto& s : stored) {
    bool found = false;
    for (const auto& kv : current) found = found || kv.first == s.first;
    if (!found) diff += "\n  " + s.first + ": only in the checkpoint (" + s.second + ")";
  }
  if (!diff.empty())
    throw Error(path, "checkpoint was written for a different problem or settings; --resume needs the same inputs and "
                      "settings (only --iters may change):" + diff);
}

}  // namespace ptir
