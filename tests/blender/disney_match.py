"""Our simplified Disney BRDF's directional albedos, for a Cycles material that matches it.

Cycles has no node for PTIR's BRDF (native/src/ptir/material/disney_brdf.h):

    f~(wo, wi) = (1-m) a/pi (1 - F(wo.h)) cos_i  +  D(h) G1(cos_i) G1(cos_o) F(wo.h) / (4 cos_o)
    F = F0 + (1 - F0) S,  S = (1 - wo.h)^5,  F0 = 0.04 (1-m) + m a
    D = GGX(alpha = max(r, 0.05)^2),  G1 = Schlick-GGX with k = alpha/2

Its diffuse term depends on the half vector, i.e. on wi, which no closure weight
can express. The matched Cycles material reproduces, for every outgoing
direction wo (through cos_o = 1 - Layer Weight "Facing"), the BRDF's
DIRECTIONAL ALBEDO exactly, lobe by lobe:

    Diffuse BSDF (Lambert) colour  Cd(x) = (1-m) (1-F0) a (1 - Sd(x))
    Glossy BSDF (GGX, roughness r) colour  Cg(x) = F0 R1(x)/RC(x) + (1-F0) RS(x)/RC(x)

with x = cos_o and
    Sd(x) = integral of S(wo.h) cos_i / pi          (the diffuse term's Schlick weight)
    R1(x) = integral of D G1 G1 / (4 cos_o)          (our specular lobe with F = 1)
    RS(x) = integral of D G1 G1 S / (4 cos_o)        (... with F = S)
    RC(x) = integral of D G1s G1s / (4 cos_o)        (Cycles' GGX lobe, separable Smith G1s)
so that under uniform illumination every wo reflects exactly what ours does; what
remains different is only how each lobe is shaped in wi (Schlick weight inside
the diffuse lobe, Schlick-GGX vs Smith masking and the Fresnel variation across
the specular lobe), a second-order effect that the Cycles comparison measures.

Pure numpy (runs in Blender's Python and in plain Python).
"""

import math

import numpy as np

MIN_ROUGHNESS = 0.05
DIELECTRIC_F0 = 0.04


def alpha_of(roughness):
    r = max(float(roughness), MIN_ROUGHNESS)
    return r * r


def _ggx_half_vectors(alpha, n_theta=768, n_phi=192):
    """Half vectors h (N, 3) with weights such that sum w g(h) = integral of D(h) cos(theta_h) g(h) dh."""
    xi = (np.arange(n_theta) + 0.5) / n_theta
    cos2 = (1.0 - xi) / (1.0 - xi + alpha * alpha * xi)  # inverse CDF of GGX NDF sampling
    cos_t = np.sqrt(cos2)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos2))
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    h = np.stack([np.outer(sin_t, np.cos(phi)), np.outer(sin_t, np.sin(phi)), np.outer(cos_t, np.ones_like(phi))], -1)
    return h.reshape(-1, 3), 1.0 / (n_theta * n_phi)


def _cosine_directions(n=512):
    u = (np.arange(n) + 0.5) / n
    r = np.sqrt(u)
    phi = u * 2.0 * math.pi
    x = np.outer(r, np.cos(phi))
    y = np.outer(r, np.sin(phi))
    z = np.sqrt(np.maximum(0.0, 1.0 - x * x - y * y))
    return np.stack([x, y, z], -1).reshape(-1, 3), 1.0 / (n * n)  # weights for integral of g cos / pi


def schlick_ggx_g1(cos_t, alpha):
    k = 0.5 * alpha
    return cos_t / (cos_t * (1.0 - k) + k)


def smith_ggx_g1(cos_t, alpha):
    c2 = np.maximum(cos_t * cos_t, 1e-12)
    tan2 = (1.0 - c2) / c2
    return 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2))


def albedo_tables(roughness, xs):
    """(Sd, R1, RS, RC) arrays over the cosines xs (see the module docstring)."""
    alpha = alpha_of(roughness)
    hs, wh = _ggx_half_vectors(alpha)
    wis, wc = _cosine_directions()
    out = {k: np.empty(len(xs)) for k in ("Sd", "R1", "RS", "RC")}
    for j, x in enumerate(xs):
        x = float(min(max(x, 1e-4), 1.0))
        wo = np.array([math.sqrt(max(0.0, 1.0 - x * x)), 0.0, x])
        # Diffuse Schlick weight over cosine-distributed wi.
        hd = wis + wo
        hd /= np.linalg.norm(hd, axis=1, keepdims=True)
        out["Sd"][j] = np.sum((1.0 - np.clip(hd @ wo, 0.0, 1.0)) ** 5) * wc
        # Specular: wi = reflect(wo, h), integral over wi of g = integral over h of D cos_h g (4 wo.h) ... / cos_h:
        # with h ~ D cos_h: integral D G F / (4 cos_o) dwi = E[G F (wo.h) / (cos_o cos_h)].
        woh = hs @ wo
        wi = 2.0 * woh[:, None] * hs - wo
        cos_i = wi[:, 2]
        ok = (woh > 0) & (cos_i > 0)
        base = np.where(ok, np.maximum(woh, 0.0) / (x * hs[:, 2]), 0.0)
        ci = np.maximum(cos_i, 1e-12)
        g_ours = schlick_ggx_g1(ci, alpha) * schlick_ggx_g1(x, alpha)
        g_cyc = smith_ggx_g1(ci, alpha) * smith_ggx_g1(np.float64(x), alpha)
        s = (1.0 - np.clip(woh, 0.0, 1.0)) ** 5
        out["R1"][j] = np.sum(base * g_ours) * wh
        out["RS"][j] = np.sum(base * g_ours * s) * wh
        out["RC"][j] = np.sum(base * g_cyc) * wh
    return out["Sd"], out["R1"], out["RS"], out["RC"]


def curve_xs(n=48):
    """Cosines at which the curves are tabulated: dense toward grazing (x -> 0)."""
    k = np.arange(n + 1) / n
    return k * k


def matched_curves(roughness, xs=None):
    """(xs, f_diffuse, f_spec_1, f_spec_s): Cd = (1-m)(1-F0) a f_diffuse, Cg = F0 f_spec_1 + (1-F0) f_spec_s."""
    xs = curve_xs() if xs is None else np.asarray(xs, np.float64)
    sd, r1, rs, rc = albedo_tables(roughness, xs)
    return xs, 1.0 - sd, r1 / rc, rs / rc


def directional_albedo_ours(base_color, roughness, metallic, x):
    """Our BRDF's directional albedo (per channel) at cos_o = x (a check of the tables)."""
    a = np.asarray(base_color, np.float64)
    sd, r1, rs, _ = albedo_tables(roughness, [x])
    f0 = DIELECTRIC_F0 * (1.0 - metallic) + metallic * a
    return (1.0 - metallic) * a * (1.0 - f0) * (1.0 - sd[0]) + f0 * r1[0] + (1.0 - f0) * rs[0]
