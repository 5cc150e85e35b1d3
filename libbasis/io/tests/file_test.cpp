// Files: checksums against a second implementation (the xxh128sum command of Debian's xxhash
// package) and the format's own test vector; atomic writers that leave nothing behind, even
// when the writing process is killed outright.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>

#include "basis/core/file_error.h"
#include "basis/io/atomic_file.h"
#include "basis/io/checksum.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;

// What `xxh128sum FILE` prints as the file's checksum.
std::string xxh128sum(const std::string& path) {
  FILE* pipe = ::popen(("xxh128sum '" + path + "'").c_str(), "r");
  if (!pipe) return "no xxh128sum";
  char line[256] = {};
  const bool read = std::fgets(line, sizeof line, pipe) != nullptr;
  ::pclose(pipe);
  if (!read) return "no output";
  return std::string(line).substr(0, std::string(line).find(' '));
}

TEST(Checksum, AgreesWithXxh128sumAndTheTestVector) {
  // XXH3-128 of no bytes, seed 0, as published with the algorithm.
  EXPECT_EQ(checksum_hex({}), "99aa06d3014798d86001c324468d497f");
  TempDir dir;
  std::mt19937_64 random(7);
  // Sizes around the algorithm's internal block and stripe sizes, and the file reader's pieces.
  for (const std::size_t size :
       {std::size_t(1), std::size_t(16), std::size_t(17), std::size_t(128), std::size_t(129),
        std::size_t(240), std::size_t(241), std::size_t(1024), std::size_t(4097),
        std::size_t(1) << 20, (std::size_t(1) << 20) + 3, std::size_t(3) << 20}) {
    std::string bytes(size, '\0');
    for (char& c : bytes)
      c = char(random());
    const std::string path = dir.file("data_" + std::to_string(size));
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(size));
    const std::string expected = xxh128sum(path);
    EXPECT_EQ(checksum_hex(std::as_bytes(std::span(bytes.data(), bytes.size()))), expected) << size;
    EXPECT_EQ(file_checksum_hex(path), expected) << size;
  }
}

TEST(Checksum, ChecksumFilesReadBackAndRefuseOtherContent) {
  TempDir dir;
  const std::string path = dir.file("a.qt");
  std::ofstream(path) << "payload";
  EXPECT_EQ(read_checksum_file(path), "");  // none yet
  const std::string hex = file_checksum_hex(path);
  write_checksum_file(path, hex);
  EXPECT_EQ(read_checksum_file(path), hex);
  // The form xxh128sum -c reads: "HEX  NAME".
  EXPECT_EQ(::system(("cd '" + dir.path() + "' && xxh128sum -c --quiet a.qt.xxh128").c_str()), 0);
  for (const std::string& bad : {hex + "  b.qt\n", hex + " a.qt\n", hex.substr(1) + "  a.qt\n",
                                 hex + "  a.qt\nmore\n", std::string("")}) {
    std::ofstream(checksum_path(path)) << bad;
    EXPECT_THROW(read_checksum_file(path), FileError) << bad;
  }
  // A name with a line break cannot stand in the file's one line: refused, nothing written,
  // and the message shows the break in one line. A line break in the folder is no matter.
  for (const std::string name : {"a\nb.qt", "c\rd.qt"}) {
    const std::string broken = dir.file(name);
    std::ofstream(broken) << "payload";
    try {
      write_checksum_file(broken, hex);
      ADD_FAILURE() << "no error for " << name;
    } catch (const FileError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.find_first_of("\n\r"), std::string::npos) << message;
      EXPECT_NE(message.find("a line break in the name"), std::string::npos) << message;
    }
    EXPECT_FALSE(std::filesystem::exists(checksum_path(broken))) << name;
  }
  std::filesystem::create_directories(dir.file("line\nbreak"));
  const std::string inside = dir.file("line\nbreak/e.qt");
  std::ofstream(inside) << "payload";
  write_checksum_file(inside, hex);
  EXPECT_EQ(read_checksum_file(inside), hex);
}

// A message that quotes a NUL byte (a file's text) keeps what follows it, the byte written \0.
TEST(FileError, NulBytesInTheMessageAreWrittenOut) {
  const FileError error(std::string("spec.json: unknown model 'a\0b'", 30));
  EXPECT_EQ(std::string(error.what()), "spec.json: unknown model 'a\\0b'");
}

TEST(AtomicFileWriter, PublishesOnlyOnCommit) {
  TempDir dir;
  const std::string path = dir.file("out.csv");
  {
    AtomicFileWriter writer(path);
    writer.write(std::string_view("a,b\n"));
    writer.write(std::string_view("1,2\n"));
    EXPECT_FALSE(std::filesystem::exists(path));
  }  // destroyed without commit: nothing
  EXPECT_TRUE(dir.entries().empty());
  AtomicFileWriter writer(path);
  writer.write(std::string_view("a,b\n"));
  writer.commit();
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.csv"});
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "a,b");
  EXPECT_THROW(AtomicFileWriter(dir.file("no/such/folder/x")), FileError);
  EXPECT_THROW(AtomicFileWriter(dir.path()), FileError);  // a folder
  // Names up to the longest a file may have: the temporary is not named after them.
  for (const std::size_t length : {200, 243, 255}) {
    const std::string name = std::string(length - 4, 'n') + ".csv";
    AtomicFileWriter long_name(dir.file(name));
    long_name.write(std::string_view("x\n"));
    long_name.commit();
    EXPECT_TRUE(std::filesystem::exists(dir.file(name))) << length;
  }
}

// Through a symbolic link to a file, both forms of atomic writing replace the link's target and
// keep the link (they replaced the link with a file of its own before).
TEST(AtomicFileWriter, WritesThroughSymbolicLinks) {
  TempDir dir;
  std::filesystem::create_directory(dir.file("data"));
  std::ofstream(dir.file("data/target.csv")) << "old\n";
  std::filesystem::create_symlink("data/target.csv", dir.file("link.csv"));
  auto read = [](const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    return line;
  };
  write_file_atomically(dir.file("link.csv"), std::as_bytes(std::span("new\n", 4)));
  EXPECT_TRUE(std::filesystem::is_symlink(dir.file("link.csv")));
  EXPECT_EQ(read(dir.file("data/target.csv")), "new");
  write_file_atomically(dir.file("link.csv"),
                        [](const std::string& temp) { std::ofstream(temp) << "newer\n"; });
  EXPECT_TRUE(std::filesystem::is_symlink(dir.file("link.csv")));
  EXPECT_EQ(read(dir.file("data/target.csv")), "newer");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"data", "link.csv"}));
  std::vector<std::string> in_data;  // no temporary left beside the target
  for (const auto& e : std::filesystem::directory_iterator(dir.file("data")))
    in_data.push_back(e.path().filename().string());
  EXPECT_EQ(in_data, std::vector<std::string>{"target.csv"});
}

TEST(AtomicFileWriter, AProcessKilledWhileWritingLeavesNothing) {
  TempDir dir;
  const std::string path = dir.file("shard.qt");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    AtomicFileWriter writer(path);
    const std::string piece(1 << 20, 'x');
    for (int k = 0; k < 8; ++k)
      writer.write(piece);
    ::kill(::getpid(), SIGKILL);  // mid-write, no destructor, no handler
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_TRUE(dir.entries().empty());  // no file and no temporary
}

}  // namespace
}  // namespace basis
