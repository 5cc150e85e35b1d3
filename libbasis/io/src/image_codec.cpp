// The image codec module: image files through OpenImageIO (see image_codec.h).
#include "image_codec.h"

#include "basis/core/version.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace basis::image_codec {
namespace {

// OpenImageIO's messages can span lines; tools print one.
std::string one_line(std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  while (!message.empty() && message.back() == ' ')
    message.pop_back();
  return message.empty() ? "unknown image error" : message;
}

std::string read(const std::string& path, long long max_pixels, int& width, int& height,
                 int& channels, std::vector<float>& pixels) {
  auto input = OIIO::ImageInput::open(path);
  if (!input) return one_line(OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) return "image has no pixels";
  if (static_cast<long long>(spec.width) * spec.height > max_pixels)
    return "image of " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
           " pixels exceeds the limit of " + std::to_string(max_pixels) + " pixels";
  width = spec.width;
  height = spec.height;
  // The first four channels at most (grey, RGB and alpha): readers use no more, and a header
  // that lists a hundred would otherwise ask memory for all of them.
  channels = std::min(spec.nchannels, 4);
  pixels.assign(std::size_t(width) * std::size_t(height) * std::size_t(channels), 0.0f);
  if (!input->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, pixels.data()))
    return one_line(input->geterror());
  input->close();
  return {};
}

// Writes `bytes` to `path`, every write checked, and flushes them to disk. Returns "" or the
// problem.
std::string write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) return std::strerror(errno);
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string problem = n < 0 ? std::strerror(errno) : "nothing written";
      ::close(fd);
      return problem;
    }
    done += std::size_t(n);
  }
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {  // EINVAL: a device, a pipe
    const std::string problem = std::strerror(errno);
    ::close(fd);
    return problem;
  }
  if (::close(fd) != 0) return std::strerror(errno);
  return {};
}

std::string write(const std::string& path, const std::string& temp_path, int width, int height,
                  int channels, const float* pixels) {
  auto output = OIIO::ImageOutput::create(path);
  if (!output) return one_line(OIIO::geterror());
  const std::string format = output->format_name();
  const bool is_float = format == "openexr" || format == "hdr";
  OIIO::ImageSpec spec(width, height, channels,
                       is_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  // No time of writing in the header (OpenEXR's capDate): the same image gives the same bytes.
  spec.attribute("DateTime", "");
  // Some of OpenImageIO's writers (PNG, small EXRs) do not report a write that failed, on a
  // full disk for one, and would leave a cut file to be put in place. Formats that can encode
  // into memory do so, and the bytes are written here, every write checked; others are read
  // back once written.
  if (output->supports("ioproxy")) {
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput memory(bytes);
    if (!output->set_ioproxy(&memory) || !output->open(temp_path, spec) ||
        !output->write_image(OIIO::TypeDesc::FLOAT, pixels) || !output->close())
      return one_line(output->geterror());
    return write_bytes(temp_path, bytes);
  }
  if (!output->open(temp_path, spec) || !output->write_image(OIIO::TypeDesc::FLOAT, pixels) ||
      !output->close())
    return one_line(output->geterror());
  auto check = OIIO::ImageInput::open(temp_path);
  std::vector<float> back(std::size_t(width) * std::size_t(height) * std::size_t(channels));
  if (!check || check->spec().width != width || check->spec().height != height ||
      !check->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, back.data()))
    return "the image written does not read back whole (is the disk full?)";
  return {};
}

constexpr Functions kFunctions{kAbiVersion, kVersion, read, write};

}  // namespace
}  // namespace basis::image_codec

extern "C" __attribute__((visibility("default"))) const basis::image_codec::Functions*
basis_image_codec_functions() {
  return &basis::image_codec::kFunctions;
}
