#include "basis/io/image_file.h"

#include "basis/core/file_error.h"
#include "basis/core/version.h"
#include "basis/io/atomic_file.h"
#include "image_codec.h"
#include "image_codec_location.h"

#include <dlfcn.h>
#include <link.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <vector>

namespace basis {
namespace {

struct LoadedCodec {
  const image_codec::Functions* functions = nullptr;
  std::string problem;  // why it could not be loaded
};

// The file of the program, or of the shared object (the Python module), that this code is
// linked into; empty if it cannot be told.
struct LinkedInto {
  std::filesystem::path file;
  bool shared_object = false;
};

LinkedInto linked_into() {
  Dl_info info{};
  link_map* map = nullptr;
  if (dladdr1(reinterpret_cast<void*>(&linked_into), &info, reinterpret_cast<void**>(&map),
              RTLD_DL_LINKMAP) != 0 &&
      map && map->l_name && map->l_name[0] != '\0')
    return {map->l_name, true};
  std::error_code error;
  return {std::filesystem::read_symlink("/proc/self/exe", error), false};  // the program
}

// The files the module is looked for in, in order: in the lib folders beside the program's
// folder (build/bin and build/lib, PREFIX/bin and PREFIX/lib or LIBDIR), beside the Python
// module's folder's parent (installed in LIBDIR/python3/dist-packages), and where the package is
// configured to install it.
std::vector<std::string> module_candidates() {
  std::vector<std::filesystem::path> folders;
  const LinkedInto linked = linked_into();
  if (linked.file.is_absolute()) {
    const std::filesystem::path beside = linked.file.parent_path();
    folders = {beside / ".." / "lib", beside / ".." / image_codec::kLibraryFolder};
    if (linked.shared_object) folders.push_back(beside / ".." / "..");
  }
  folders.push_back(image_codec::kInstalledFolder);
  std::vector<std::string> files;
  for (const std::filesystem::path& folder : folders)
    files.push_back((folder / image_codec::kModuleName).lexically_normal().string());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

// The module in `file` (a path, or a name the library path resolves), if it loads and is this
// version's; otherwise null, and `problem` says why. A module is never unloaded: the image
// library it loads stays in use.
const image_codec::Functions* open_module(const std::string& file, std::string& problem) {
  void* module = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!module) {
    const char* why = dlerror();
    const std::string message = why ? why : "cannot be loaded";
    problem = message.rfind(file, 0) == 0 ? message : file + ": " + message;
    return nullptr;
  }
  using Entry = const image_codec::Functions* (*)();
  const auto entry = reinterpret_cast<Entry>(dlsym(module, image_codec::kEntryPoint));
  const image_codec::Functions* functions = entry ? entry() : nullptr;
  if (functions && functions->abi_version == image_codec::kAbiVersion &&
      std::string(functions->project_version) == kVersion)
    return functions;
  problem = file + " is not the image module of libbasis " + kVersion;
  return nullptr;
}

// The first candidate that loads and is this version's module, else by name on the library
// path. A file that fails (another version, not a shared object, a library it needs missing) is
// passed over, and named if none loads.
LoadedCodec load_codec() {
  const std::vector<std::string> candidates = module_candidates();
  LoadedCodec loaded;
  for (const std::string& file : candidates) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(file, error)) continue;
    std::string problem;
    if ((loaded.functions = open_module(file, problem))) return loaded;
    if (loaded.problem.empty()) loaded.problem = problem;
  }
  std::string not_on_the_path;
  if ((loaded.functions = open_module(image_codec::kModuleName, not_on_the_path))) return loaded;
  if (loaded.problem.empty()) {
    loaded.problem = std::string(image_codec::kModuleName) + " not found in ";
    for (const std::string& file : candidates)
      loaded.problem += std::filesystem::path(file).parent_path().string() + ", ";
    loaded.problem += "or on the library path";
  }
  return loaded;
}

// The codec module, loaded on the first image read or written and kept for the process; a
// module that could not be loaded is looked for again at the next image.
const image_codec::Functions& codec(const std::string& path) {
  static std::mutex mutex;
  static const image_codec::Functions* functions = nullptr;
  const std::lock_guard lock(mutex);
  if (!functions) {
    const LoadedCodec loaded = load_codec();
    if (!loaded.functions)
      throw FileError(path + ": cannot load the image library: " + loaded.problem);
    functions = loaded.functions;
  }
  return *functions;
}

}  // namespace

Image read_image(const std::string& path) {
  // Said here: some of OpenImageIO's readers (HEIF) spin on a directory instead of failing.
  check_regular_file(path, "an image");
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

void write_images(const std::vector<NamedImage>& images) {
  namespace fs = std::filesystem;
  // Each temporary keeps its destination's extension, which picks the format.
  std::vector<std::string> written;
  auto remove_written = [&] {
    std::error_code ignored;
    for (const std::string& temp : written)
      fs::remove(temp, ignored);
  };
  // A device or a pipe is written in place, as write_image writes it.
  for (const NamedImage& named : images) {
    std::error_code error;
    if (fs::exists(named.path, error) && !fs::is_regular_file(named.path, error) &&
        !fs::is_directory(named.path, error)) {
      for (const NamedImage& each : images)
        write_image(each.path, *each.image);
      return;
    }
  }
  // Through a symbolic link to a file, the file is written and the link kept.
  std::vector<std::string> targets;
  for (const NamedImage& named : images)
    targets.push_back(through_links(named.path));
  try {
    for (std::size_t k = 0; k < images.size(); ++k) {
      const NamedImage& named = images[k];
      std::error_code error;
      if (fs::is_directory(named.path, error))
        throw FileError(named.path + ": is a directory, not an image");
      const fs::path path(targets[k]);
      std::string name = ".";
      name += path.stem().string();
      name += ".partial-";
      name += std::to_string(::getpid());
      name += path.extension().string();
      const std::string temp = (path.parent_path() / name).string();
      written.push_back(temp);
      try {
        write_image(temp, *named.image);
      } catch (const FileError& e) {  // named after the destination, not the temporary
        const std::string what = e.what();
        throw FileError(what.rfind(temp, 0) == 0 ? named.path + what.substr(temp.size()) : what);
      }
    }
    for (std::size_t k = 0; k < images.size(); ++k) {
      std::error_code error;
      fs::rename(written[k], targets[k], error);
      if (error) throw FileError(images[k].path + ": " + error.message());
    }
  } catch (...) {
    remove_written();
    throw;
  }
}

}  // namespace basis
