// SceneAccel::walk_packet against the naive reference (every Gaussian evaluated
// for every ray, then sorted) and against SceneAccel::walk, lane by lane: the same
// hits, bit for bit, in the same order, and the same ends. Packets of every width
// (the SSE2 and AVX2 evaluations), shared and separate origins, several rounds,
// meshes, and visitors that stop lanes early.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "reference_hits.h"
#include "test_scenes.h"

using namespace ptir;

namespace {

// The reference hits (reference_hits.h) of accel's Gaussians under its cull settings.
std::vector<GaussianHit> naive_hits(const SceneAccel& accel, const Ray& r, float t_end) {
  return test::naive_hits(accel.trace_data(), r, t_end, accel.settings().cull);
}

// Closest mesh hit of the quads used here (planes z = const), by hand.
float wall_t(const Ray& r, const std::vector<TriangleMesh>& meshes) {
  float best = r.tmax;
  for (const TriangleMesh& m : meshes) {
    float z0 = m.vertices[0].z, h = m.vertices[1].x;
    if (r.d.z == 0) continue;
    float t = (z0 - r.o.z) / r.d.z;
    Vec3 p = r.at(t);
    if (t >= r.tmin && t < best && std::fabs(p.x) <= h && std::fabs(p.y) <= h) best = t;
  }
  return best;
}

struct LaneResult {
  std::vector<GaussianHit> hits;
  WalkEnd end;
};

// Compositing visitor (stops at T < min_transmittance), optionally stopping each
// lane after stop_after[lane] hits as well.
std::vector<LaneResult> packet_hits(const SceneAccel& accel, const std::vector<Ray>& rays, bool stop_when_opaque,
                                    const std::vector<int>& stop_after = {}) {
  const float min_T = accel.settings().cull.min_transmittance;
  std::vector<LaneResult> out(rays.size());
  std::vector<float> T(rays.size(), 1.0f);
  WalkEnd ends[SceneAccel::kMaxPacket];
  accel.walk_packet(
      rays.data(), int(rays.size()),
      [&](int lane, const GaussianHit& h) {
        out[lane].hits.push_back(h);
        T[lane] *= 1 - h.alpha;
        if (!stop_after.empty() && int(out[lane].hits.size()) >= stop_after[lane]) return false;
        return T[lane] >= min_T;
      },
      ends, nullptr, stop_when_opaque);
  for (size_t l = 0; l < rays.size(); ++l) out[l].end = ends[l];
  return out;
}

LaneResult single_hits(const SceneAccel& accel, const Ray& r, bool stop_when_opaque, int stop_after = -1) {
  const float min_T = accel.settings().cull.min_transmittance;
  LaneResult out;
  float T = 1;
  out.end = accel.walk(
      r,
      [&](const GaussianHit& h) {
        out.hits.push_back(h);
        T *= 1 - h.alpha;
        if (stop_after >= 0 && int(out.hits.size()) >= stop_after) return false;
        return T >= min_T;
      },
      nullptr, stop_when_opaque);
  return out;
}

void expect_same_end(const WalkEnd& a, const WalkEnd& b, const std::string& what) {
  EXPECT_EQ(a.stopped, b.stopped) << what;
  ASSERT_EQ(a.mesh.valid, b.mesh.valid) << what;
  if (a.mesh.valid) {
    EXPECT_EQ(a.mesh.t, b.mesh.t) << what;
    EXPECT_EQ(a.mesh.mesh, b.mesh.mesh) << what;
    EXPECT_EQ(a.mesh.prim, b.mesh.prim) << what;
  }
}

// n rays from one origin (camera-like, a small cone) or from random origins.
std::vector<Ray> make_packet(std::mt19937& rng, int n, bool shared_origin) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Ray> rays(n);
  Vec3 o = normalize(Vec3(u(rng), u(rng), u(rng))) * 3.0f;
  Vec3 target(u(rng) * 0.6f, u(rng) * 0.6f, u(rng) * 0.6f);
  for (Ray& r : rays) {
    if (shared_origin) {
      r.o = o;
      r.d = normalize(target + Vec3(u(rng), u(rng), u(rng)) * 0.15f - o);
    } else {
      // Incoherent: origins outside or inside the cube, any direction.
      bool inside = u(rng) > 0.5f;
      r.o = inside ? Vec3(u(rng), u(rng), u(rng)) * 0.8f : normalize(Vec3(u(rng), u(rng), u(rng))) * 3.0f;
      r.d = inside ? normalize(Vec3(u(rng), u(rng), u(rng)))
                   : normalize(Vec3(u(rng), u(rng), u(rng)) * 0.7f - r.o);
    }
  }
  return rays;
}

}  // namespace

class PacketWalkVsNaive : public ::testing::TestWithParam<int> {};

TEST_P(PacketWalkVsNaive, EveryLaneMatchesNaiveAndWalk) {
  const int k = GetParam();
  GaussianField field = test::random_field(300, 11);
  AccelSettings settings;
  settings.k = k;
  SceneAccel accel(field, {}, settings);
  std::mt19937 rng(5);
  size_t total = 0;
  for (int p = 0; p < 64; ++p) {
    const int n = 1 + p % SceneAccel::kMaxPacket;  // every width: 4-, 8- and 16-ray packets
    const bool shared = p % 2 == 0;
    std::vector<Ray> rays = make_packet(rng, n, shared);
    for (bool opaque_walk : {false, true}) {
      std::vector<LaneResult> got = packet_hits(accel, rays, opaque_walk);
      for (int l = 0; l < n; ++l) {
        std::string what = "packet " + std::to_string(p) + " lane " + std::to_string(l);
        test::expect_same_hits(got[l].hits, naive_hits(accel, rays[l], rays[l].tmax), what);
        LaneResult one = single_hits(accel, rays[l], opaque_walk);
        test::expect_same_hits(got[l].hits, one.hits, what);
        expect_same_end(got[l].end, one.end, what);
        total += got[l].hits.size();
      }
    }
  }
  EXPECT_GT(total, 4000u);  // the rays really cross the field
}

INSTANTIATE_TEST_SUITE_P(KBuffer, PacketWalkVsNaive, ::testing::Values(1, 3, 16, 64));

TEST(PacketWalk, LanesFinishAtDifferentRounds) {
  // Faint Gaussians on the z axis, rays of different lengths: with k = 4 the lanes
  // need from 6 to 25 rounds; each must still see exactly its own hits.
  GaussianField field;
  for (int i = 0; i < 100; ++i) test::add_gaussian(field, Vec3(0, 0, -0.05f * i), Vec3(0.1f), {1, 0, 0, 0}, 0.05f);
  SceneAccel accel(field, {}, AccelSettings{CullSettings{}, 4});
  std::vector<Ray> rays(8);
  for (int l = 0; l < 8; ++l) {
    rays[l] = Ray{Vec3(0.01f * l, 0, 1), Vec3(0, 0, -1)};
    rays[l].tmax = 2.02f + 0.6f * float(l);
  }
  TraceStats stats;
  std::vector<LaneResult> got(8);
  WalkEnd ends[8];
  accel.walk_packet(rays.data(), 8, [&](int l, const GaussianHit& h) { got[l].hits.push_back(h); return true; }, ends,
                    &stats);
  for (int l = 0; l < 8; ++l) {
    test::expect_same_hits(got[l].hits, naive_hits(accel, rays[l], rays[l].tmax), "lane " + std::to_string(l));
    test::expect_same_hits(got[l].hits, single_hits(accel, rays[l], false).hits, "lane " + std::to_string(l));
  }
  EXPECT_EQ(got[0].hits.size(), 21u);
  EXPECT_EQ(got[7].hits.size(), 100u);
  EXPECT_GT(stats.rounds, 8u * 5u);
  EXPECT_GT(stats.packet_rounds, 20u);
}

TEST(PacketWalk, VisitorStopsLanesIndependently) {
  GaussianField field = test::random_field(400, 3, 0.05f, 0.25f);
  SceneAccel accel(field, {}, AccelSettings{CullSettings{}, 3});
  std::mt19937 rng(8);
  for (int p = 0; p < 20; ++p) {
    std::vector<Ray> rays = make_packet(rng, 16, p % 2 == 0);
    std::vector<int> stop_after(16);
    for (int l = 0; l < 16; ++l) stop_after[l] = 1 + (l * 7 + p) % 9;
    std::vector<LaneResult> got = packet_hits(accel, rays, false, stop_after);
    for (int l = 0; l < 16; ++l) {
      LaneResult one = single_hits(accel, rays[l], false, stop_after[l]);
      test::expect_same_hits(got[l].hits, one.hits, "lane " + std::to_string(l));
      expect_same_end(got[l].end, one.end, "lane " + std::to_string(l));
    }
  }
}

TEST(PacketWalk, MeshesEndLanesLikeWalk) {
  // Walls inside a dense field: lanes end at a wall, turn opaque, or leave the field.
  GaussianField field = test::random_field(3000, 41, 0.03f, 0.15f);
  std::vector<TriangleMesh> meshes = {test::quad_z(0.3f, 0.5f), test::quad_z(-0.4f, 0.7f)};
  for (int k : {2, 32}) {
    AccelSettings settings;
    settings.k = k;
    SceneAccel accel(field, meshes, settings);
    std::mt19937 rng(17);
    int mesh_lanes = 0, opaque_lanes = 0;
    for (int p = 0; p < 24; ++p) {
      std::vector<Ray> rays = make_packet(rng, 1 + (5 * p) % 16, p % 3 != 0);
      for (bool opaque_walk : {false, true}) {
        std::vector<LaneResult> got = packet_hits(accel, rays, opaque_walk);
        for (size_t l = 0; l < rays.size(); ++l) {
          std::string what = "k " + std::to_string(k) + " packet " + std::to_string(p) + " lane " + std::to_string(l);
          LaneResult one = single_hits(accel, rays[l], opaque_walk);
          test::expect_same_hits(got[l].hits, one.hits, what);
          expect_same_end(got[l].end, one.end, what);
          // Against the reference where the lane is not grazing a wall's edge.
          float t_mesh = wall_t(rays[l], meshes);
          if (got[l].end.mesh.valid || got[l].end.stopped || !std::isfinite(t_mesh))
            test::expect_same_hits(got[l].hits, naive_hits(accel, rays[l], t_mesh), what);
          mesh_lanes += got[l].end.mesh.valid;
          opaque_lanes += got[l].end.stopped;
        }
      }
    }
    EXPECT_GT(mesh_lanes, 20) << "k=" << k;
    EXPECT_GT(opaque_lanes, 20) << "k=" << k;
  }
}

TEST(PacketWalk, StatsCountLanes) {
  GaussianField field = test::random_field(300, 11);
  SceneAccel accel(field, {}, AccelSettings{CullSettings{}, 16});
  std::mt19937 rng(2);
  std::vector<Ray> rays = make_packet(rng, 8, true);
  TraceStats packet, single;
  WalkEnd ends[8];
  accel.walk_packet(rays.data(), 8, [](int, const GaussianHit&) { return true; }, ends, &packet);
  for (const Ray& r : rays) accel.walk(r, [](const GaussianHit&) { return true; }, &single);
  EXPECT_EQ(packet.hits, single.hits);
  EXPECT_EQ(packet.rounds, single.rounds);
  EXPECT_GE(packet.packet_rounds, 1u);
  EXPECT_EQ(single.packet_rounds, 0u);
  EXPECT_THROW(accel.walk_packet(rays.data(), SceneAccel::kMaxPacket + 1, [](int, const GaussianHit&) { return true; },
                                 ends),
               Error);
}
