#include "basis/io/image_file.h"

#include "basis/io/atomic_file.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <filesystem>
#include <memory>

namespace basis {

namespace {

// OpenImageIO's messages can span lines; tools print one.
std::string one_line(std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  while (!message.empty() && message.back() == ' ')
    message.pop_back();
  return message.empty() ? "unknown image error" : message;
}

}  // namespace

Image read_image(const std::string& path) {
  // Said here: some of OpenImageIO's readers (HEIF) spin on a directory instead of failing.
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw FileError(path + ": is a directory, not an image");
  auto input = OIIO::ImageInput::open(path);
  if (!input) throw FileError(path + ": " + one_line(OIIO::geterror()));
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw FileError(path + ": image has no pixels");
  if (static_cast<long long>(spec.width) * spec.height > kMaxImagePixels)
    throw FileError(path + ": image of " + std::to_string(spec.width) + " x " +
                    std::to_string(spec.height) + " pixels exceeds the limit of " +
                    std::to_string(kMaxImagePixels) + " pixels");
  Image image(spec.width, spec.height, spec.nchannels);
  if (!input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
    throw FileError(path + ": " + one_line(input->geterror()));
  input->close();
  return image;
}

void write_image(const std::string& path, const Image& image) {
  auto output = OIIO::ImageOutput::create(path);
  if (!output) throw FileError(path + ": " + one_line(OIIO::geterror()));
  const bool is_float = std::string(output->format_name()) == "openexr" ||
                        std::string(output->format_name()) == "hdr";
  OIIO::ImageSpec spec(image.width, image.height, image.channels,
                       is_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  write_file_atomically(path, [&](const std::string& temp) {
    if (!output->open(temp, spec)) throw FileError(path + ": " + one_line(output->geterror()));
    if (!output->write_image(OIIO::TypeDesc::FLOAT, image.pixels.data()))
      throw FileError(path + ": " + one_line(output->geterror()));
    if (!output->close()) throw FileError(path + ": " + one_line(output->geterror()));
  });
}

}  // namespace basis
