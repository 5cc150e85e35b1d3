#include "basis/io/image_file.h"

#include "basis/core/version.h"
#include "basis/io/atomic_file.h"
#include "image_codec.h"
#include "image_codec_location.h"

#include <dlfcn.h>
#include <link.h>

#include <filesystem>

namespace basis {
namespace {

struct LoadedCodec {
  const image_codec::Functions* functions = nullptr;
  std::string problem;  // why it could not be loaded
};

// The program, or the shared object (the Python module), that this code is linked into.
std::filesystem::path linked_into() {
  Dl_info info{};
  link_map* map = nullptr;
  if (dladdr1(reinterpret_cast<void*>(&linked_into), &info, reinterpret_cast<void**>(&map),
              RTLD_DL_LINKMAP) != 0 &&
      map && map->l_name && map->l_name[0] != '\0')
    return map->l_name;
  std::error_code error;
  return std::filesystem::read_symlink("/proc/self/exe", error);  // the program itself
}

// The module is looked for in the lib folders beside the program's folder (build/bin and
// build/lib, PREFIX/bin and PREFIX/lib), beside the Python module's folder's parent (installed
// in LIBDIR/python3/dist-packages), then where the package is configured to install it; the
// first file found is the one loaded.
LoadedCodec load_codec() {
  const std::filesystem::path beside = linked_into().parent_path();
  const std::filesystem::path candidates[] = {
      beside / ".." / "lib" / image_codec::kModuleName,
      beside / ".." / image_codec::kLibraryFolder / image_codec::kModuleName,
      beside / ".." / ".." / image_codec::kModuleName, image_codec::kInstalledModule};
  LoadedCodec loaded;
  for (const std::filesystem::path& candidate : candidates) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(candidate, error)) continue;
    const std::string file = candidate.lexically_normal().string();
    void* module = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!module) {
      const char* why = dlerror();
      loaded.problem = why ? why : file + ": cannot be loaded";
      return loaded;
    }
    using Entry = const image_codec::Functions* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(module, image_codec::kEntryPoint));
    const image_codec::Functions* functions = entry ? entry() : nullptr;
    if (functions && functions->abi_version == image_codec::kAbiVersion &&
        std::string(functions->project_version) == kVersion) {
      loaded.functions = functions;
      return loaded;
    }
    dlclose(module);
    loaded.problem = file + " is not the image module of libbasis " + kVersion;
    return loaded;
  }
  loaded.problem = std::string(image_codec::kModuleName) + " is in none of " +
                   (beside / ".." / "lib").lexically_normal().string() + ", " +
                   image_codec::kInstalledModule;
  return loaded;
}

// The codec module, loaded on the first image read or written and kept for the process.
const image_codec::Functions& codec(const std::string& path) {
  static const LoadedCodec loaded = load_codec();
  if (!loaded.functions)
    throw FileError(path + ": cannot load the image library: " + loaded.problem);
  return *loaded.functions;
}

}  // namespace

Image read_image(const std::string& path) {
  // Said here: some of OpenImageIO's readers (HEIF) spin on a directory instead of failing.
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw FileError(path + ": is a directory, not an image");
  Image image;
  const std::string problem = codec(path).read(path, kMaxImagePixels, image.width, image.height,
                                               image.channels, image.pixels);
  if (!problem.empty()) throw FileError(path + ": " + problem);
  return image;
}

void write_image(const std::string& path, const Image& image) {
  const image_codec::Functions& functions = codec(path);
  write_file_atomically(path, [&](const std::string& temp) {
    const std::string problem =
        functions.write(path, temp, image.width, image.height, image.channels, image.pixels.data());
    if (!problem.empty()) throw FileError(path + ": " + problem);
  });
}

}  // namespace basis
