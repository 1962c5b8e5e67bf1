"""Minimal OpenEXR reading and writing in pure Python + numpy.

Why: Blender 3.4's Image.save() writes generated float images display-encoded,
and reading EXR through bpy.data.images mixes in Blender's colour management and
alpha conventions. This module writes and reads the bytes directly, so the
values on disk are exactly the linear floats we computed.

Supported: scanline files, single-part or multi-part (Blender 5.0 writes multilayer EXRs as one part
per pass, named "<view layer>.<pass>"), channels HALF or FLOAT (UINT read too), compression NONE, ZIPS
(1 line per block) or ZIP (16 lines per block). That covers what Blender's File Output node and
multilayer render output write with codec NONE/ZIP and what OpenImageIO writes by default (ZIP).
"""

import struct
import zlib

import numpy as np

_MAGIC = 20000630
_PIXEL_DTYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_LINES_PER_BLOCK = {0: 1, 2: 1, 3: 16}  # NONE, ZIPS, ZIP


def _attr(name, type_name, payload):
    return name.encode() + b"\0" + type_name.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def write_exr(path, image, channels=None):
    """Writes an (H, W) or (H, W, C) float array as an uncompressed 32-bit float EXR.

    channels: names for the C channels (default Y; R,G,B; R,G,B,A). Row 0 of the
    array is the top row of the image. EXR colour is associated with alpha: pass
    premultiplied colour when there is an A channel.
    """
    a = np.asarray(image, dtype=np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    h, w, c = a.shape
    if channels is None:
        channels = {1: ["Y"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}[c]
    if len(channels) != c:
        raise ValueError("need %d channel names, got %r" % (c, channels))
    order = sorted(range(c), key=lambda i: channels[i])  # EXR stores channels sorted by name
    chlist = b"".join(channels[i].encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for i in order) + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = struct.pack("<ii", _MAGIC, 2)
    header += _attr("channels", "chlist", chlist)
    header += _attr("compression", "compression", b"\0")
    header += _attr("dataWindow", "box2i", box)
    header += _attr("displayWindow", "box2i", box)
    header += _attr("lineOrder", "lineOrder", b"\0")
    header += _attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    header += _attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
    header += _attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    header += b"\0"
    line_bytes = w * c * 4
    first = len(header) + 8 * h
    offsets = struct.pack("<%dQ" % h, *[first + y * (8 + line_bytes) for y in range(h)])
    planar = np.ascontiguousarray(a[:, :, order].transpose(0, 2, 1)).astype("<f4")  # (H, C, W)
    with open(path, "wb") as f:
        f.write(header)
        f.write(offsets)
        for y in range(h):
            f.write(struct.pack("<ii", y, line_bytes))
            f.write(planar[y].tobytes())


def _read_attrs(buf, pos):
    attrs = {}
    while buf[pos] != 0:
        end = buf.index(b"\0", pos)
        name = buf[pos:end].decode()
        tend = buf.index(b"\0", end + 1)
        type_name = buf[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", buf, tend + 1)
        attrs[name] = (type_name, buf[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return attrs, pos + 1


def _read_headers(buf):
    """([attrs of each part], position after the headers, multi-part?)."""
    magic, version = struct.unpack_from("<ii", buf, 0)
    if magic != _MAGIC:
        raise ValueError("not an OpenEXR file")
    if version & 0x200:
        raise ValueError("tiled EXR files are not supported")
    if not version & 0x1000:
        attrs, pos = _read_attrs(buf, 8)
        return [attrs], pos, False
    parts, pos = [], 8
    while buf[pos] != 0:
        attrs, pos = _read_attrs(buf, pos)
        if attrs.get("type", ("", b"scanlineimage\0"))[1].rstrip(b"\0") != b"scanlineimage":
            raise ValueError("only scanline parts of multi-part EXR files are supported")
        parts.append(attrs)
    return parts, pos + 1, True


def _channels(payload):
    out, pos = [], 0
    while payload[pos] != 0:
        end = payload.index(b"\0", pos)
        name = payload[pos:end].decode()
        ptype, _, xs, ys = struct.unpack_from("<iB3xii", payload, end + 1)
        if xs != 1 or ys != 1:
            raise ValueError("subsampled channels are not supported")
        out.append((name, _PIXEL_DTYPES[ptype]))
        pos = end + 1 + 16
    return out


def _unzip(data, expected):
    raw = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int64)
    if raw.size != expected:
        raise ValueError("corrupt ZIP block")
    # Undo the predictor, then re-interleave the two halves.
    t = (np.cumsum(np.concatenate([[0], raw[1:] - 128])) + raw[0]) & 0xFF
    t = t.astype(np.uint8)
    half = (expected + 1) // 2
    out = np.empty(expected, np.uint8)
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def _part_layout(path, attrs):
    chans = _channels(attrs["channels"][1])
    comp = attrs.get("compression", ("", b"\0"))[1][0]
    if comp not in _LINES_PER_BLOCK:
        raise ValueError("%s: EXR compression %d is not supported (use NONE or ZIP)" % (path, comp))
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    return chans, _LINES_PER_BLOCK[comp], (x0, y0, x1, y1)


def _read_block(buf, off, layout, out, multi):
    chans, lines, (x0, y0, x1, y1) = layout
    w = x1 - x0 + 1
    head = 12 if multi else 8
    y, size = struct.unpack_from("<ii", buf, off + head - 8)
    data = buf[off + head:off + head + size]
    n = min(lines, y1 - y + 1)
    expected = sum(dt.itemsize for _, dt in chans) * w * n
    if size < expected:
        data = _unzip(data, expected)
    p = 0
    for row in range(n):
        for name, dt in chans:
            out[name][y - y0 + row] = np.frombuffer(data, dt, w, p).astype(np.float32)
            p += dt.itemsize * w


def read_exr(path):
    """Reads a scanline EXR: returns {channel name: (H, W) float32 array}, row 0 = top. Channels of a
    multi-part file are named "<part name>.<channel>" (unless their own name already has a dot)."""
    with open(path, "rb") as f:
        buf = f.read()
    parts, pos, multi = _read_headers(buf)
    result = {}
    for attrs in parts:
        layout = _part_layout(path, attrs)
        chans, lines, (x0, y0, x1, y1) = layout
        w, h = x1 - x0 + 1, y1 - y0 + 1
        nblocks = (h + lines - 1) // lines
        offsets = struct.unpack_from("<%dQ" % nblocks, buf, pos)
        pos += 8 * nblocks
        out = {name: np.empty((h, w), np.float32) for name, _ in chans}
        for off in offsets:
            _read_block(buf, off, layout, out, multi)
        prefix = attrs["name"][1].rstrip(b"\0").decode() + "." if multi and "name" in attrs else ""
        for name, a in out.items():
            result[name if "." in name or not prefix else prefix + name] = a
    return result


def read_exr_array(path, names):
    """The channels `names` (e.g. "RGBA") stacked as (H, W, len(names)); missing ones raise KeyError."""
    ch = read_exr(path)
    return np.stack([ch[n] for n in names], axis=-1)
