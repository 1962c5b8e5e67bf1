// GaussianField helpers: SH preview colour and the initial shading normals.
#include "ptir/scene/gaussians.h"

#include <algorithm>

namespace ptir {

namespace {

// Real SH constants of the 3DGS reference code (utils/sh_utils.py).
constexpr float kC0 = 0.28209479177387814f;
constexpr float kC1 = 0.4886025119029199f;
constexpr float kC2[5] = {1.0925484305920792f, -1.0925484305920792f, 0.31539156525252005f, -1.0925484305920792f,
                          0.5462742152960396f};
constexpr float kC3[7] = {-0.5900435899266435f, 2.890611442640554f, -0.4570457994644658f, 0.3731763325901154f,
                          -0.4570457994644658f, 1.445305721320277f, -0.5900435899266435f};
// Degree 4, in the order and signs of the 3DGS family's eval_sh (gsplat, svox2).
constexpr float kC4[9] = {2.5033429417967046f,  -1.7701307697799304f, 0.9461746957575601f,
                          -0.6690465435572892f, 0.10578554691520431f, -0.6690465435572892f,
                          0.47308734787878004f, -1.7701307697799304f, 0.6258357354491761f};

}  // namespace

// Same basis order and signs as eval_sh() in the INRIA code; dir is the ray
// direction (camera to Gaussian).
Vec3 GaussianField::sh_colour(size_t i, Vec3 dir) const {
  const int stride = sh_stride();
  if (sh.size() < (i + 1) * static_cast<size_t>(stride)) return Vec3(0.5f);
  const float* c = sh.data() + i * static_cast<size_t>(stride);
  auto coef = [c](int k) { return Vec3(c[k * 3 + 0], c[k * 3 + 1], c[k * 3 + 2]); };

  Vec3 result = kC0 * coef(0);
  if (sh_degree > 0) {
    const Vec3 d = normalize(dir);
    const float x = d.x, y = d.y, z = d.z;
    result += -kC1 * y * coef(1) + kC1 * z * coef(2) - kC1 * x * coef(3);
    if (sh_degree > 1) {
      const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
      result += kC2[0] * xy * coef(4) + kC2[1] * yz * coef(5) + kC2[2] * (2.0f * zz - xx - yy) * coef(6) +
                kC2[3] * xz * coef(7) + kC2[4] * (xx - yy) * coef(8);
      if (sh_degree > 2) {
        result += kC3[0] * y * (3.0f * xx - yy) * coef(9) + kC3[1] * xy * z * coef(10) +
                  kC3[2] * y * (4.0f * zz - xx - yy) * coef(11) +
                  kC3[3] * z * (2.0f * zz - 3.0f * xx - 3.0f * yy) * coef(12) +
                  kC3[4] * x * (4.0f * zz - xx - yy) * coef(13) + kC3[5] * z * (xx - yy) * coef(14) +
                  kC3[6] * x * (xx - 3.0f * yy) * coef(15);
      }
      if (sh_degree > 3) {  // the basis's own degree-4 values (sh_basis)
        float y4[kMaxShCoefficients];
        sh_basis(4, d, y4);
        for (int k = 16; k < 25; ++k) result += y4[k] * coef(k);
      }
    }
  }
  return vmax(result + Vec3(0.5f), Vec3(0.0f));
}

void sh_basis(int degree, Vec3 dir, float* out) {
  out[0] = kC0;
  if (degree < 1) return;
  const Vec3 d = normalize(dir);
  const float x = d.x, y = d.y, z = d.z;
  out[1] = -kC1 * y, out[2] = kC1 * z, out[3] = -kC1 * x;
  if (degree < 2) return;
  const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
  out[4] = kC2[0] * xy, out[5] = kC2[1] * yz, out[6] = kC2[2] * (2.0f * zz - xx - yy), out[7] = kC2[3] * xz;
  out[8] = kC2[4] * (xx - yy);
  if (degree < 3) return;
  out[9] = kC3[0] * y * (3.0f * xx - yy), out[10] = kC3[1] * xy * z, out[11] = kC3[2] * y * (4.0f * zz - xx - yy);
  out[12] = kC3[3] * z * (2.0f * zz - 3.0f * xx - 3.0f * yy), out[13] = kC3[4] * x * (4.0f * zz - xx - yy);
  out[14] = kC3[5] * z * (xx - yy), out[15] = kC3[6] * x * (xx - 3.0f * yy);
  if (degree < 4) return;
  out[16] = kC4[0] * xy * (xx - yy), out[17] = kC4[1] * yz * (3.0f * xx - yy);
  out[18] = kC4[2] * xy * (7.0f * zz - 1.0f), out[19] = kC4[3] * yz * (7.0f * zz - 3.0f);
  out[20] = kC4[4] * (zz * (35.0f * zz - 30.0f) + 3.0f), out[21] = kC4[5] * xz * (7.0f * zz - 3.0f);
  out[22] = kC4[6] * (xx - yy) * (7.0f * zz - 1.0f), out[23] = kC4[7] * xz * (xx - 3.0f * yy);
  out[24] = kC4[8] * (xx * (xx - 3.0f * yy) - yy * (3.0f * xx - yy));
}

// The local axis with the smallest standard deviation (first one on ties).
void init_normals_shortest_axis(GaussianField& field) {
  const size_t n = field.size();
  field.normal.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 s = field.scale[i];
    int axis = 0;
    if (s.y < s[axis]) axis = 1;
    if (s.z < s[axis]) axis = 2;
    field.normal[i] = normalize(field.rotation_matrix(i).col(axis));
  }
}

// Flip n_i when it points toward the centroid of all Gaussian centres.
void orient_normals_away_from_centroid(GaussianField& field, const std::vector<uint8_t>* only_these) {
  const size_t n = field.size();
  if (n == 0) return;
  double c[3] = {0, 0, 0};
  for (const Vec3& p : field.position)
    for (int k = 0; k < 3; ++k) c[k] += p[k];
  const Vec3 centroid(static_cast<float>(c[0] / n), static_cast<float>(c[1] / n), static_cast<float>(c[2] / n));
  for (size_t i = 0; i < n && i < field.normal.size(); ++i) {
    if (only_these && (i >= only_these->size() || (*only_these)[i] == 0)) continue;
    if (dot(field.normal[i], field.position[i] - centroid) < 0.0f) field.normal[i] = -field.normal[i];
  }
}

}  // namespace ptir
