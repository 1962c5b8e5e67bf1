// SuperSplat / PlayCanvas "compressed PLY" splats: 256 splats per chunk, each
// chunk storing float bounds, each splat four packed uint32 words, optional
// 8-bit SH in a separate "sh" element. Decoded here to the standard INRIA 3DGS
// layout so the rest of the pipeline never sees the packed form.
#pragma once

#include <string>

#include "ptir/io/ply.h"

namespace ptir::io {

// True when the file looks like a compressed splat PLY: an element "chunk" and a
// "vertex" element with packed_* properties.
bool is_compressed_splat_ply(const PlyFile& ply);

// Returns a PlyFile whose "vertex" element holds x,y,z, f_dc_0..2, f_rest_* (when
// the file has SH), opacity (logit), scale_0..2 (log), rot_0..3 (w,x,y,z) as float32,
// followed by any other vertex properties of the input. Other elements (except
// "chunk" and "sh") are copied unchanged. Throws ptir::Error(path, why) when the
// file cannot be decoded (missing bounds, wrong types, too few chunks, ...).
PlyFile decode_compressed_splat_ply(const PlyFile& ply, const std::string& path);

}  // namespace ptir::io
