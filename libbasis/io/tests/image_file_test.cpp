// Image files: the image library is loaded on the first image written or read, not when the
// program starts; what is written reads back (floats exactly in EXR, 8 bits clamped in PNG).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "basis/io/image_file.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

bool image_library_loaded() {
  std::ifstream maps("/proc/self/maps");
  const std::string text((std::istreambuf_iterator<char>(maps)), std::istreambuf_iterator<char>());
  return text.find("libOpenImageIO") != std::string::npos;
}

TEST(ImageFile, TheImageLibraryLoadsOnTheFirstImageAndWhatIsWrittenReadsBack) {
  EXPECT_FALSE(image_library_loaded());
  testing::TempDir dir;
  Image image(3, 2, 3);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = float(i) * 0.0625f + (i == 4 ? 1e5f : 0.0f);
  write_image(dir.file("small.exr"), image);
  EXPECT_TRUE(image_library_loaded());
  const Image exr = read_image(dir.file("small.exr"));
  ASSERT_EQ(exr.width, 3);
  ASSERT_EQ(exr.height, 2);
  ASSERT_EQ(exr.channels, 3);
  EXPECT_EQ(exr.pixels, image.pixels);

  write_image(dir.file("small.png"), image);
  const Image png = read_image(dir.file("small.png"));
  ASSERT_EQ(png.pixels.size(), image.pixels.size());
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    EXPECT_NEAR(png.pixels[i], std::min(image.pixels[i], 1.0f), 0.501f / 255) << i;

  try {
    read_image(dir.file("missing.exr"));
    ADD_FAILURE() << "a missing image was read";
  } catch (const FileError& error) {
    EXPECT_EQ(std::string(error.what()).rfind(dir.file("missing.exr") + ": ", 0), 0u)
        << error.what();
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"small.exr", "small.png"}));
}

// Only the first four channels are read (readers use grey, RGB and alpha): a file of many
// channels reads as its first four, where it asked memory for all of them.
TEST(ImageFile, ManyChannelsReadAsTheirFirstFour) {
  testing::TempDir dir;
  Image image(4, 2, 7);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = float(i);
  write_image(dir.file("seven.exr"), image);
  const Image read = read_image(dir.file("seven.exr"));
  ASSERT_EQ(read.channels, 4);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 4; ++c)
        EXPECT_EQ(read.at(x, y, c), image.at(x, y, c)) << x << " " << y << " " << c;
}

// Images written together (a render's EXR and PNG) go through a symbolic link to a file: the
// file is replaced, the link kept, and no temporary is left in either folder.
TEST(ImageFile, WrittenTogetherThroughSymbolicLinks) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("data"));
  Image old_image(2, 2, 3), new_image(2, 2, 3);
  for (std::size_t i = 0; i < new_image.pixels.size(); ++i)
    new_image.pixels[i] = 0.25f * float(i);
  write_image(dir.file("data/render.exr"), old_image);
  std::filesystem::create_symlink("data/render.exr", dir.file("render.exr"));
  write_images({{dir.file("render.exr"), &new_image}, {dir.file("render.png"), &new_image}});
  EXPECT_TRUE(std::filesystem::is_symlink(dir.file("render.exr")));
  EXPECT_EQ(read_image(dir.file("data/render.exr")).pixels, new_image.pixels);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"data", "render.exr", "render.png"}));
  std::vector<std::string> in_data;
  for (const auto& e : std::filesystem::directory_iterator(dir.file("data")))
    in_data.push_back(e.path().filename().string());
  EXPECT_EQ(in_data, std::vector<std::string>{"render.exr"});
}

}  // namespace
}  // namespace basis
