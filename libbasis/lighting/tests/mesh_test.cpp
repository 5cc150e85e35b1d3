// OBJ and MTL files against what the formats say they hold: a vertex has x, y and z; a face's
// normal indices name normals the file has; an emission Ke of one number is grey (g and b equal
// to r, the MTL convention); a negative emission reads as 0 with a warning.
#include <gtest/gtest.h>

#include <string>

#include "basis/core/file_error.h"
#include "basis/lighting/mesh.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;
using testing::write_text;

// The FileError read_obj throws for `path`, or "" when it reads the file.
std::string read_error(const std::string& path) {
  try {
    read_obj(path);
  } catch (const FileError& e) {
    return e.what();
  }
  return "";
}

TEST(ObjFile, AVertexWithoutThreeCoordinatesIsAnError) {
  TempDir dir;
  // The reader took the missing z as 0, without a word.
  write_text(dir.file("short.obj"), "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(read_error(dir.file("short.obj")).find("short.obj:2: vertex 2 has 2 coordinates"),
            std::string::npos)
      << read_error(dir.file("short.obj"));
  write_text(dir.file("one.obj"), "v 0 0 0\nv 1 0 0\n  v 7\nf 1 2 3\n");
  EXPECT_NE(read_error(dir.file("one.obj")).find("one.obj:3: vertex 3 has 1 coordinate,"),
            std::string::npos);
  // Four (a weight) are read as before.
  write_text(dir.file("weighted.obj"), "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n");
  EXPECT_EQ(read_error(dir.file("weighted.obj")), "");
}

TEST(ObjFile, ANormalIndexPastTheNormalsIsAnError) {
  TempDir dir;
  // The reader kept the face, and its corners took the face's normal, without a word.
  write_text(dir.file("normals.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//5\n");
  EXPECT_NE(read_error(dir.file("normals.obj")).find("face 1 uses normal 5 of 1"),
            std::string::npos)
      << read_error(dir.file("normals.obj"));
  // A relative index before the first normal, which the reader took for "no normal".
  for (const std::string index : {"-2", "-3"}) {
    write_text(dir.file("before.obj"),
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//" + index + "\n");
    EXPECT_NE(read_error(dir.file("before.obj"))
                  .find("before.obj:5: face index '" + index + "' names a normal before the first"),
              std::string::npos)
        << read_error(dir.file("before.obj"));
  }
  write_text(dir.file("fine.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//-1\n");
  const TriangleMesh fine = read_obj(dir.file("fine.obj"));
  ASSERT_EQ(fine.corner_normals.size(), 1u);
  EXPECT_EQ(fine.corner_normals[0][2][2], 1.0f);
}

TEST(ObjFile, EmissionOfOneNumberIsGreyAndNegativeEmissionIsZeroWithAWarning) {
  TempDir dir;
  write_text(dir.file("lights.mtl"),
             "newmtl grey\nKe 2\n\nnewmtl colour\nKe 1 0.5 0.25\n\n"
             "newmtl negative\nKe -5 -5 -5\n");
  write_text(dir.file("lights.obj"),
             "mtllib lights.mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 0 0 2\nv 1 0 2\nv 0 1 2\n"
             "v 0 0 3\nv 1 0 3\nv 0 1 3\n"
             "usemtl grey\nf 1 2 3\nusemtl colour\nf 4 5 6\nusemtl negative\nf 7 8 9\n");
  const TriangleMesh mesh = read_obj(dir.file("lights.obj"));
  ASSERT_EQ(mesh.emission.size(), 3u);
  EXPECT_EQ(mesh.emission[0], (Color{2, 2, 2}));  // it was (2, 0, 0): a red light
  EXPECT_EQ(mesh.emission[1], (Color{1, 0.5, 0.25}));
  EXPECT_EQ(mesh.emission[2], (Color{0, 0, 0}));
  ASSERT_EQ(mesh.reader_warnings.size(), 1u);
  EXPECT_NE(mesh.reader_warnings[0].find("material 'negative': negative emission Ke read as 0"),
            std::string::npos)
      << mesh.reader_warnings[0];
  // Lines that end at a lone carriage return, a comment after the number, and a name defined
  // twice (faces use the first definition, as the reader keeps it): each read as written.
  write_text(dir.file("forms.mtl"),
             "newmtl cr\rKe 3\rnewmtl comment\nKe 4 # a lamp\nnewmtl twice\nKe 1 0 0\n"
             "newmtl twice\nKe 5\n");
  write_text(dir.file("forms.obj"),
             "mtllib forms.mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\n"
             "usemtl cr\nf 1 2 3\nusemtl comment\nf 1 2 3\nusemtl twice\nf 1 2 3\n");
  const TriangleMesh forms = read_obj(dir.file("forms.obj"));
  ASSERT_EQ(forms.emission.size(), 3u);
  EXPECT_EQ(forms.emission[0], (Color{3, 3, 3}));
  EXPECT_EQ(forms.emission[1], (Color{4, 4, 4}));
  EXPECT_EQ(forms.emission[2], (Color{1, 0, 0}));
}

}  // namespace
}  // namespace basis
