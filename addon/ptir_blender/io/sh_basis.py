"""The real spherical-harmonic basis as 3DGS files use it: the degree-0 constant.

A splat's SH DC coefficient f_dc stores its view-independent colour c as
c = 0.5 + SH_C0 * f_dc (display-encoded, as 3DGS trainers store it).
"""

SH_C0 = 0.28209479177387814  # Y_0^0 = 1 / (2 sqrt(pi))


def dc_of_colour(c):
    """The SH DC coefficient (c - 0.5) / SH_C0 of a display colour c (array or scalar)."""
    return (c - 0.5) / SH_C0
