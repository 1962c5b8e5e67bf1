// Photos and maps (io/image.cpp through OpenImageIO): the first byte picks the
// extension (.exr or .png), the rest is the file. Seeds: tests/fuzz/corpus/image/.
#include <OpenImageIO/imageio.h>

#include "fuzz_common.h"
#include "ptir/core/error.h"
#include "ptir/io/exr_header.h"
#include "ptir/io/image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Only the reader the extension names (EXR, PNG): when it fails, OpenImageIO otherwise
  // tries every reader it has, and DCMTK's DICOM reader (loading its dictionary on each
  // try) grew past 2.5 GiB within a few hundred inputs (finding, third-party; README).
  static const bool one_reader = OIIO::attribute("try_all_readers", 0);
  (void)one_reader;
  if (size < 1) return 0;
  const std::string name = (data[0] & 1) ? "in.exr" : "in.png";
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / name, data + 1, size - 1);
  // read_image checks an EXR's header attributes against the file before OpenEXR reads
  // them; the probe below opens the file with OpenImageIO itself, so it does too.
  try {
    ptir::io::check_exr_header(path, size - 1);
  } catch (const ptir::Error&) {
    return 0;
  }
  // Confinement: headers declaring more than 1M values are real images' business (read_image
  // refuses past 2^31 values before allocating), not the fuzzer's 2 GiB memory limit's.
  if (auto in = OIIO::ImageInput::open(path)) {
    const OIIO::ImageSpec& s = in->spec();
    if (double(s.width) * double(s.height) * double(s.nchannels) > double(1 << 20)) return 0;
  }
  ptir_fuzz::expect_only_ptir_errors([&] { ptir::read_image(path, ptir::Encoding::Colour); });
  return 0;
}
