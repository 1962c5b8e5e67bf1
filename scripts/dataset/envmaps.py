"""Synthetic HDR environment maps (lat-long, linear RGB) in Blender's orientation.

Texel (x, y) of a W x H map (row 0 = top of the file) covers u in [x/W, (x+1)/W)
and theta = pi (y + 0.5) / H from +z; the direction of u is
phi = (0.5 - u) 2 pi, i.e. u = 0.5 is +x and u = 0.25 is +y: exactly the
Environment Texture node's default mapping and ptir's Environment::load
(native/src/ptir/lights/environment.h). Values are radiance, strength 1.

Each map is a sky gradient (zenith / horizon / ground colours) plus a few
spherical-Gaussian "lamps" L = c exp(lambda (d.mu - 1)). They are smooth enough
that 64-spp Cycles renders are not dominated by noise, and different enough
(colour, direction, sharpness) that relighting is a real test.
"""

import math

import numpy as np


def direction(azimuth_deg, elevation_deg):
    """Unit vector; azimuth from +x toward +y, elevation above the xy plane."""
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def texel_directions(width, height):
    """(H, W, 3) unit directions of the texel centres."""
    u = (np.arange(width) + 0.5) / width
    theta = math.pi * (np.arange(height) + 0.5) / height
    phi = (0.5 - u) * 2.0 * math.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    return np.stack([st * np.cos(phi)[None, :], st * np.sin(phi)[None, :], np.broadcast_to(ct, (height, width))], -1)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# name -> (zenith, horizon, ground, [(colour, azimuth, elevation, sharpness), ...])
PRESETS = {
    # Training light: a neutral room with a big warm key light up-front-right, a
    # cool fill on the other side and a dim floor. Broad lobes: soft shading and
    # wide highlights that still reveal roughness.
    "studio": ((0.30, 0.30, 0.32), (0.34, 0.33, 0.32), (0.10, 0.10, 0.10),
               [((4.0, 3.7, 3.3), 35.0, 40.0, 12.0),
                ((0.9, 1.1, 1.5), 215.0, 25.0, 5.0),
                ((1.2, 1.2, 1.2), 300.0, 70.0, 8.0)]),
    # Relight 1: a low orange sun under a purple-blue sky, dark ground.
    "sunset": ((0.10, 0.14, 0.32), (0.75, 0.42, 0.25), (0.06, 0.05, 0.045),
               [((14.0, 7.0, 3.0), 250.0, 10.0, 60.0),
                ((0.6, 0.3, 0.2), 250.0, 5.0, 4.0)]),
    # Relight 2: a clear blue sky with a high white sun on the other side, green ground.
    "sky": ((0.20, 0.38, 0.80), (0.60, 0.70, 0.85), (0.12, 0.16, 0.08),
            [((16.0, 15.0, 13.5), 120.0, 60.0, 100.0)]),
    # Relight 3: an overcast day -- a bright, nearly uniform grey sky, a soft brighter
    # patch where the sun hides, warm grey ground.
    "overcast": ((0.62, 0.64, 0.68), (0.52, 0.52, 0.53), (0.16, 0.14, 0.12),
                 [((1.6, 1.6, 1.7), 30.0, 45.0, 3.0)]),
    # The family's training lights (docs/family.md). Sun and sky: a small bright warm-white sun high up
    # over a blue sky (hard shadows, a blue fill).
    "sunsky": ((0.12, 0.25, 0.60), (0.45, 0.55, 0.70), (0.10, 0.09, 0.08),
               [((30.0, 27.0, 22.0), 60.0, 50.0, 250.0)]),
    # Strongly coloured: an orange room, an orange key and a magenta fill (the light's colour is far
    # from white: what an albedo must not take for its own).
    "coloured": ((0.30, 0.14, 0.05), (0.36, 0.18, 0.07), (0.08, 0.04, 0.02),
                 [((4.5, 2.0, 0.6), 35.0, 40.0, 12.0),
                  ((1.3, 0.3, 1.0), 215.0, 25.0, 5.0)]),
    # Coloured the other way: a teal room with a cyan key.
    "tinted": ((0.06, 0.22, 0.30), (0.08, 0.25, 0.30), (0.03, 0.06, 0.07),
               [((1.0, 3.2, 3.8), 300.0, 45.0, 10.0),
                ((0.8, 1.2, 0.6), 120.0, 20.0, 5.0)]),
    # Dim: the studio at a fifth of its radiance (darker 8-bit images, more of them in the low codes).
    "dim": ((0.06, 0.06, 0.064), (0.068, 0.066, 0.064), (0.02, 0.02, 0.02),
            [((0.8, 0.74, 0.66), 35.0, 40.0, 12.0),
             ((0.18, 0.22, 0.30), 215.0, 25.0, 5.0),
             ((0.24, 0.24, 0.24), 300.0, 70.0, 8.0)]),
}


def make_envmap(name, width=128, height=64):
    """The preset `name` as an (H, W, 3) float32 array."""
    zenith, horizon, ground, lamps = PRESETS[name]
    d = texel_directions(width, height)
    z = d[..., 2:3]
    sky = np.asarray(horizon) + (np.asarray(zenith) - np.asarray(horizon)) * _smoothstep(0.0, 0.8, z)
    img = np.where(z >= 0.0, sky, np.asarray(ground) + (np.asarray(horizon) - np.asarray(ground)) * _smoothstep(-0.15, 0.0, z))
    for colour, az, el, sharp in lamps:
        mu = direction(az, el)
        img = img + np.asarray(colour) * np.exp(sharp * (d @ mu - 1.0))[..., None]
    return img.astype(np.float32)


def lookup(env, dirs):
    """Radiance of a lat-long map (H, W, 3) in the directions dirs (..., 3): the texel
    containing each direction (the inverse of texel_directions' mapping)."""
    h, w = env.shape[:2]
    d = np.asarray(dirs, np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    theta = np.arccos(np.clip(d[..., 2], -1.0, 1.0))
    u = (0.5 - np.arctan2(d[..., 1], d[..., 0]) / (2.0 * math.pi)) % 1.0
    x = np.minimum((u * w).astype(int), w - 1)
    y = np.minimum((theta / math.pi * h).astype(int), h - 1)
    return env[y, x]
