// The Python module `basis`: .qt files, trees as NumPy arrays, projection, convolution, table
// lookups, BRDF models and tables, captures. A thin layer: every computation is the library's;
// errors become exceptions with the library's one-line messages (FileError: basis.Error,
// std::invalid_argument: ValueError), and long calls release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/brdf_table.h"
#include "basis/brdf/table_lookup.h"
#include "basis/core/convolution.h"
#include "basis/core/file_error.h"
#include "basis/core/projection.h"
#include "basis/core/task.h"
#include "basis/core/version.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/io/image_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/capture_inputs.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/mesh.h"
#include "basis/lighting/shading.h"

namespace py = pybind11;

namespace basis::python {
namespace {

// What a view lives on: a loaded file, or a tree, table or capture set made here.
using Owner = std::shared_ptr<const void>;

struct Tree {
  Owner owner;
  PackedTreeView view;
  ProjectionOptions projection;  // how it was cut: written with it
};

struct Table {
  Owner owner;
  BrdfTableView view;
  std::string model, spec;
  ProjectionOptions projection;
  std::shared_ptr<const QtFile> file;  // when loaded: its spec's data files are found from it
  std::optional<Brdf> brdf;            // when tabulated here: the BRDF itself
  std::string source;      // the spec file it was tabulated from (its provenance's, if loaded)
  std::string parameters;  // the options it was tabulated with, as provenance JSON
  // When loaded: the BRDF rebuilt from its spec the first time lights need it (shared by the
  // table's copies; only touched with the GIL held), or why it could not be.
  struct Rebuilt {
    bool tried = false;
    std::optional<Brdf> brdf;
    std::string problem;
  };
  std::shared_ptr<Rebuilt> rebuilt = std::make_shared<Rebuilt>();
};

struct Captures {
  Owner owner;
  CaptureSetView view;
  ProjectionOptions projection;
  std::optional<CaptureRecipe> recipe;  // when made here: written into the file's provenance
  // When loaded: the file's provenance, parameters and sources, written back with the set.
  std::optional<Provenance> loaded;
};

struct File {
  std::shared_ptr<const QtFile> file;
};

struct PyBrdf {
  BrdfSpec spec;       // the BRDF, its model, the spec's text and its "table" block
  std::string source;  // the spec file, empty for a spec given as text
};

Provenance python_provenance(const std::string& parameters = "{}", const std::string& source = "") {
  Provenance p{"basis (Python)", kVersion, parameters, {}};
  if (!source.empty()) p.sources.push_back(source);
  return p;
}

// What a capture set written from here records: its recipe and the files it read (map, scene)
// when made here, the provenance it was loaded with otherwise.
Provenance captures_provenance(const Captures& c) {
  if (c.recipe) {
    Provenance p = python_provenance(capture_parameters(*c.recipe));
    for (const std::string& file : {c.recipe->environment, c.recipe->scene})
      if (!file.empty()) p.sources.push_back(file);
    return p;
  }
  if (c.loaded) return *c.loaded;
  return python_provenance();
}

// Capture k of a set, k < 0 counting from the end as Python does; IndexError outside.
std::size_t capture_index(const Captures& c, long long k) {
  const long long n = static_cast<long long>(c.view.size());
  if (k < -n || k >= n)
    throw py::index_error("capture " + std::to_string(k) + " of a set of " + std::to_string(n));
  return std::size_t(k < 0 ? k + n : k);
}

// Capture k's radiance tree (Captures.tree and indexing).
Tree capture_tree(const Captures& c, long long k) {
  return Tree{c.owner, c.view.trees.tree(capture_index(c, k)), c.projection};
}

// A path argument: str, bytes or os.PathLike, as the file system's bytes (os.fsencode, so that
// names that are not UTF-8 pass as they are), without NUL characters (which would cut it short).
std::string path_of(const py::object& path, const std::string& what) {
  const py::bytes encoded = py::module_::import("os").attr("fsencode")(path);
  const std::string s = encoded;
  if (s.find('\0') != std::string::npos)
    throw std::invalid_argument(what + " contains a NUL character");
  // An empty path names no file (an unset variable, most often): never "no scene" or the like.
  if (s.empty()) throw std::invalid_argument(what + " is empty: it names no file");
  return s;
}

Vec3 to_vec3(const std::array<double, 3>& a) {
  return {a[0], a[1], a[2]};
}

// The unit vector along v whatever its length; ValueError naming `what` for a zero or
// non-finite vector.
Vec3 to_direction(const Vec3& v, const std::string& what) {
  const Vec3 unit = unit_direction(v);
  if (unit == Vec3::Zero()) throw std::invalid_argument(what + " must be a finite non-zero vector");
  return unit;
}

// The unit vectors along vectors[k], for every k; ValueError naming name[k] for the first that is
// zero or not finite (the name made only then).
std::vector<Vec3> to_directions(const std::vector<Vec3>& vectors, const char* name) {
  std::vector<Vec3> units(vectors.size());
  for (std::size_t k = 0; k < vectors.size(); ++k) {
    units[k] = unit_direction(vectors[k]);
    if (units[k] == Vec3::Zero())
      to_direction(vectors[k], std::string(name) + "[" + std::to_string(k) + "]");
  }
  return units;
}

py::array_t<double> rgb_array(const Rgb& v) {
  py::array_t<double> out(3);
  for (int c = 0; c < 3; ++c)
    out.mutable_at(c) = v[c];
  return out;
}

py::tuple result(const Convolution& c) {
  return py::make_tuple(rgb_array(c.value), rgb_array(c.bound));
}

// An N x 3 array of doubles from vectors (a copy).
py::array_t<double> vectors(std::span<const Vec3> v) {
  py::array_t<double> out({py::ssize_t(v.size()), py::ssize_t(3)});
  auto a = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c)
      a(py::ssize_t(i), c) = v[i][c];
  return out;
}

std::vector<Vec3> to_vectors(
    const py::array_t<double, py::array::c_style | py::array::forcecast>& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument(std::string(what) + " must be an N x 3 array");
  std::vector<Vec3> out(std::size_t(a.shape(0)));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    out[std::size_t(i)] = {r(i, 0), r(i, 1), r(i, 2)};
  return out;
}

WoInterpolation interpolation_of(const std::string& name) {
  if (name == "hermite") return WoInterpolation::hermite;
  if (name == "bilinear") return WoInterpolation::bilinear;
  throw std::invalid_argument("interpolation must be 'hermite' or 'bilinear', got '" + name + "'");
}

BoundKind bounds_of(const std::string& name) {
  if (name == "l2") return BoundKind::l2;
  if (name == "linf") return BoundKind::linf;
  throw std::invalid_argument("bounds must be 'l2' or 'linf', got '" + name + "'");
}

// A grid from an array of shape (N, N), (C, N, N) or (G, C, N, N), float texel averages.
// A NumPy grid as texels: indexed [v, u] in each plane (row y = v, column x = u), as Grid is.
// Finite values beyond the largest float are refused (std::overflow_error) rather than read as
// infinities.
Grid to_grid(const py::array_t<double, py::array::c_style | py::array::forcecast>& a) {
  std::array<py::ssize_t, 4> shape{1, 1, 0, 0};
  if (a.ndim() == 0)
    throw py::type_error(
        "a grid is an array of shape (N, N), (C, N, N) or (G, C, N, N), not a "
        "single value");
  if (a.ndim() == 2)
    shape = {1, 1, a.shape(0), a.shape(1)};
  else if (a.ndim() == 3)
    shape = {1, a.shape(0), a.shape(1), a.shape(2)};
  else if (a.ndim() == 4)
    shape = {a.shape(0), a.shape(1), a.shape(2), a.shape(3)};
  else
    throw std::invalid_argument("a grid is an array of shape (N, N), (C, N, N) or (G, C, N, N)");
  if (shape[2] != shape[3]) throw std::invalid_argument("a grid must be square");
  if (shape[1] != 1 && shape[1] != 3) throw std::invalid_argument("a grid has 1 or 3 channels");
  if (shape[0] < 1 || shape[0] > 3) throw std::invalid_argument("a grid has 1 to 3 groups");
  if (!is_valid_resolution(int(shape[2])))
    throw std::invalid_argument("a grid's side must be a power of two from 2 to 512, got " +
                                std::to_string(shape[2]));
  Grid grid{int(shape[2]), int(shape[1]), int(shape[0])};
  const double* values = a.data();
  for (std::size_t k = 0; k < grid.texels.size(); ++k) {
    if (std::isfinite(values[k]) && std::abs(values[k]) > std::numeric_limits<float>::max()) {
      char text[64];
      std::snprintf(text, sizeof text, "%.3g", values[k]);
      throw std::overflow_error(std::string("a texel of ") + text +
                                " lies beyond what floats hold (3.4e38)");
    }
    grid.texels[k] = float(values[k]);
  }
  return grid;
}

py::array_t<float> grid_array(Grid grid) {
  py::array_t<float> out({py::ssize_t(grid.groups), py::ssize_t(grid.channels),
                          py::ssize_t(grid.resolution), py::ssize_t(grid.resolution)});
  std::copy(grid.texels.begin(), grid.texels.end(), out.mutable_data());
  return out;
}

Tree own(PackedTree tree, const ProjectionOptions& projection) {
  auto held = std::make_shared<const PackedTree>(std::move(tree));
  return {held, held->view(), projection};
}

Table own(BrdfTable table, const ProjectionOptions& projection) {
  auto held = std::make_shared<const BrdfTable>(std::move(table));
  return {held, held->view(), held->model, held->spec, projection, nullptr, std::nullopt, "", "{}"};
}

// The BRDF that shades a capture set's lights: the one the table tabulates, rebuilt from its
// spec once per table; none (the table's texels then, with a RuntimeWarning as qtconvolve's)
// when the spec cannot be rebuilt, as for a measured BRDF whose data file moved. Needs the GIL.
const Brdf* table_brdf_of(const Table& table) {
  if (table.brdf) return &*table.brdf;
  Table::Rebuilt& rebuilt = *table.rebuilt;
  if (!rebuilt.tried && table.file) {
    rebuilt.tried = true;
    try {
      rebuilt.brdf = table_brdf(*table.file).brdf;
    } catch (const FileError& e) {
      rebuilt.problem = std::string(e.what()) + "; directional lights use the table's texels";
    }
  }
  if (!rebuilt.problem.empty() &&
      PyErr_WarnEx(PyExc_RuntimeWarning, rebuilt.problem.c_str(), 1) != 0)
    throw py::error_already_set();
  return rebuilt.brdf ? &*rebuilt.brdf : nullptr;
}

// The threads of a call's arena: 0 for every core, else 1..1024 as the tools take them.
int arena_threads(int threads) {
  if (threads < 0 || threads > 1024)
    throw std::invalid_argument("threads must be 0 (every core) or 1..1024, got " +
                                std::to_string(threads));
  // No more than the cores: oneTBB runs no more, and asking for more prints its own warning.
  return threads > 0 ? std::min(threads, tbb::info::default_concurrency())
                     : tbb::task_arena::automatic;
}

// Runs work(control) on a thread of its own (without the GIL: it must not touch Python objects)
// while this one looks for signals every 50 ms. On one (Ctrl-C), the control asks the work to stop,
// and the exception the signal's handler raised (KeyboardInterrupt) is raised once it has. Needs
// the GIL.
template <class Work>
auto run_interruptible(Work&& work) -> decltype(work(std::declval<const TaskControl&>())) {
  using Result = decltype(work(std::declval<const TaskControl&>()));
  std::atomic<bool> cancel{false};
  TaskControl control;
  control.cancel = &cancel;
  std::packaged_task<Result()> task([&] { return work(control); });
  std::future<Result> done = task.get_future();
  std::optional<py::error_already_set> signal;
  {
    py::gil_scoped_release release;
    std::thread worker(std::move(task));
    try {
      while (done.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
        if (signal) continue;
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) {
          signal.emplace();  // takes the handler's exception
          cancel = true;
        }
      }
    } catch (...) {  // the work is stopped and waited for, whatever failed here
      cancel = true;
      worker.join();
      throw;
    }
    worker.join();
  }
  if (signal) throw std::move(*signal);
  return done.get();  // the work's own exception, if it threw one
}

// Issues each line as a RuntimeWarning (an exception when the warnings filter makes it one).
// Needs the GIL.
void warn_each(const std::vector<std::string>& lines) {
  for (const std::string& line : lines)
    if (PyErr_WarnEx(PyExc_RuntimeWarning, line.c_str(), 1) != 0) throw py::error_already_set();
}

// Objects of the module's classes are made by its functions. A bare Class.__new__(Class), which
// generic copying code may call, would give one whose C++ value was never made: it raises.
void refuse_bare_new(const py::object& cls) {
  const std::string name = py::str(cls.attr("__name__"));
  cls.attr("__new__") = py::staticmethod(py::cpp_function(
      [name](const py::args&, const py::kwargs&) -> py::object {
        throw py::type_error("basis." + name +
                             " objects are made by the module's functions (load, project, "
                             "tabulate, capture, Brdf.from_json, ...), not directly");
      },
      py::name("__new__")));
}

// Raises `type` with `message`, whose bytes that are not UTF-8 (a file's own, quoted in a
// parse error) are escaped rather than losing the whole message.
void set_python_error(PyObject* type, const char* message) {
  PyObject* text =
      PyUnicode_DecodeUTF8(message, Py_ssize_t(std::strlen(message)), "backslashreplace");
  if (!text) return;  // the decoding's own error stands
  PyErr_SetObject(type, text);
  Py_DECREF(text);
}

}  // namespace

PYBIND11_MODULE(basis, m) {
  m.doc() =
      "libbasis: BRDFs and hemisphere captures of HDR lighting as quadtrees in a hierarchical "
      "piecewise-constant basis over the cosine-weighted concentric map, convolved with a "
      "certified error bound.";
  m.attr("__version__") = kVersion;
  static py::exception<FileError> error(m, "Error", PyExc_RuntimeError);
  error.attr("__doc__") =
      "A file that cannot be read or written: missing, corrupt, of another kind, or an I/O "
      "error. The message names the file and the problem in one line.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      set_python_error(error.ptr(), e.what());
    } catch (const std::invalid_argument& e) {
      set_python_error(PyExc_ValueError, e.what());
    } catch (const std::overflow_error& e) {
      set_python_error(PyExc_OverflowError, e.what());
    } catch (const std::length_error& e) {  // a size past the format's limits, not memory
      set_python_error(PyExc_ValueError, e.what());
    }
  });

  py::class_<Tree>(
      m, "Tree",
      "A packed quadtree over the unit square (the cosine-weighted concentric map): "
      "quadrant values scaled per tree (half floats, or shared-exponent words in RGB captures), "
      "8-bit certified bounds.")
      .def_property_readonly(
          "resolution", [](const Tree& t) { return t.view.shape().resolution; },
          "N: the tree covers an N x N grid of texels of the cosine-weighted concentric map.")
      .def_property_readonly(
          "channels", [](const Tree& t) { return t.view.shape().channels; }, "1 (grey) or 3 (RGB).")
      .def_property_readonly(
          "groups", [](const Tree& t) { return t.view.shape().groups; },
          "Channel groups: 1, or 3 for a table entry with its derivatives over wo (f, h df/ds, h "
          "df/dt).")
      .def_property_readonly(
          "bounded_groups", [](const Tree& t) { return t.view.shape().bounded_groups; },
          "Groups 0 .. bounded_groups - 1 carry certified bounds.")
      .def_property_readonly(
          "bounds",
          [](const Tree& t) { return t.view.shape().bounds == BoundKind::l2 ? "l2" : "linf"; },
          "What the bounds bound: 'l2', each quadrant's RMS deviation from its value, or 'linf', "
          "its largest.")
      .def_property_readonly(
          "node_count", [](const Tree& t) { return t.view.node_count(); },
          "Nodes, texel nodes included.")
      .def_property_readonly(
          "words_per_node", [](const Tree& t) { return t.view.shape().words_per_node(); },
          "32-bit words of a full node: link, values, bound codes.")
      .def_property_readonly(
          "value_scale", [](const Tree& t) { return t.view.scales().value_scale; },
          "A power of two: a stored value times it is the quadrant's value.")
      .def_property_readonly(
          "bound_scale", [](const Tree& t) { return t.view.scales().bound_scale; },
          "A bound code's value times it is the quadrant's bound.")
      .def_property_readonly(
          "texel_start", [](const Tree& t) { return t.view.texel_start(); },
          "Nodes from here on are texel nodes, values alone (trees with exact texels); node_count "
          "otherwise.")
      .def_property_readonly(
          "shared_values", [](const Tree& t) { return t.view.shape().shared_values(); },
          "Whether the nodes hold their values as shared-exponent words, one per quadrant (RGB "
          "captures since format 6), rather than halves.")
      .def_property_readonly(
          "words",
          [](py::object self) {
            const Tree& t = self.cast<const Tree&>();
            const py::ssize_t per_node = t.view.shape().words_per_node();
            // The full nodes where they lie (a view into the file or tree), read-only.
            py::array_t<std::uint32_t> a({py::ssize_t(t.view.texel_start()), per_node},
                                         {per_node * 4, py::ssize_t(4)}, t.view.words().data(),
                                         self);
            py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return a;
          },
          "The full nodes without a copy: an array of texel_start x words_per_node 32-bit words "
          "(link, values, bound codes; README, the .qt file format). Every node but the "
          "texel nodes of trees with exact texels (texel_words).")
      .def_property_readonly(
          "texel_words",
          [](py::object self) {
            const Tree& t = self.cast<const Tree&>();
            const py::ssize_t per_node = t.view.shape().words_per_texel_node();
            const py::ssize_t count = t.view.node_count() - t.view.texel_start();
            py::array_t<std::uint32_t> a({count, per_node}, {per_node * 4, py::ssize_t(4)},
                                         count ? t.view.node(t.view.texel_start()) : nullptr, self);
            py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return a;
          },
          "The texel nodes of a tree with exact texels (a capture's), nodes texel_start on, "
          "without a copy: their values alone, a shared-exponent word per texel in RGB trees "
          "(9-bit "
          "mantissas, bits 0-26, and a 5-bit exponent, bits 27-31), halves otherwise (empty for "
          "trees without exact texels).")
      .def(
          "reconstruct",
          [](const Tree& t) {
            Grid grid;
            {
              py::gil_scoped_release release;
              grid = reconstruct(t.view);
            }
            return grid_array(std::move(grid));
          },
          "The piecewise-constant function at full resolution: float32 (groups, channels, N, N), "
          "each plane indexed [v, u] as project() takes it.")
      .def(
          "integrate",
          [](const Tree& t, int group, int channel) {
            if (group < 0 || group >= t.view.shape().groups || channel < 0 ||
                channel >= t.view.shape().channels)
              throw std::invalid_argument("no group " + std::to_string(group) + ", channel " +
                                          std::to_string(channel) + " in this tree");
            return integrate(t.view, group, channel);
          },
          py::arg("group") = 0, py::arg("channel") = 0,
          "The integral over the unit square of one group and channel: the root's average as "
          "stored (2^-11 relative in halves; in captures' shared-exponent words 1/511.5 of the "
          "largest channel), within the tree's bound of the source grid's mean.");

  m.def(
      "project",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& grid,
         double tolerance, bool absolute, const std::string& bounds) {
        ProjectionOptions options;
        options.tolerance = tolerance;
        options.mode =
            absolute ? ProjectionOptions::Mode::absolute : ProjectionOptions::Mode::relative;
        const Grid g = to_grid(grid);
        const BoundKind kind = bounds_of(bounds);
        py::gil_scoped_release release;
        return own(pack(project(g, options), kind), options);
      },
      py::arg("grid"), py::arg("tolerance") = 0.05, py::arg("absolute") = false,
      py::arg("bounds") = "l2",
      "A grid of texel averages (N x N, C x N x N or G x C x N x N; each plane indexed [v, u], "
      "rows v downwards, columns u) projected into a packed tree: a quadrant is refined while "
      "its bound exceeds tolerance times the channel's mean (or tolerance itself with "
      "absolute=True). Values beyond floats raise OverflowError.");

  m.def(
      "convolve",
      [](const Tree& a, const Tree& b, double accuracy, bool bound) {
        Convolution c;
        {
          py::gil_scoped_release release;
          c = convolve(a.view, b.view, {accuracy, bound});
        }
        return result(c);
      },
      py::arg("a"), py::arg("b"), py::arg("accuracy") = 0.0, py::arg("bound") = true,
      "The integral over the unit square of a * b and its certified bound, as (value, bound) "
      "RGB arrays (the hemisphere integral of A B cos is pi times it). bound=False: the same "
      "value, faster, and a bound of inf (not with an accuracy target).");

  py::class_<Table>(m, "Table", "A BRDF table: quadtrees over wi at a parabolic grid of wo.")
      .def_property_readonly(
          "wo_resolution", [](const Table& t) { return t.view.wo_resolution; },
          "M: the table has M x M entries over the parabolic map of wo.")
      .def_property_readonly(
          "has_tilt", [](const Table& t) { return t.view.has_tilt(); },
          "Whether the entries carry tilt derivatives (for reflect_tilted's compensation).")
      .def_property_readonly(
          "has_wo_derivatives", [](const Table& t) { return t.view.has_wo_derivatives(); },
          "Whether the entries hold their derivatives over wo (groups 1 and 2), for Hermite "
          "lookups between entries.")
      .def_property_readonly(
          "model", [](const Table& t) { return t.model; },
          "The BRDF model's name (phong, ggx, ...).")
      .def_property_readonly(
          "spec", [](const Table& t) { return t.spec; }, "The JSON spec the table was made from.")
      .def(
          "entry",
          [](const Table& t, int i, int j) {
            const int m = t.view.wo_resolution;
            if (i < 0 || j < 0 || i >= m || j >= m)
              throw py::index_error("entry (" + std::to_string(i) + ", " + std::to_string(j) +
                                    ") outside the " + std::to_string(m) + " x " +
                                    std::to_string(m) + " table");
            return Tree{t.owner, t.view.entry(i, j), t.projection};
          },
          py::arg("i"), py::arg("j"),
          "The entry at wo's parabolic coordinates s = -1 + 2 i / (M - 1), t = -1 + 2 j / (M - 1) "
          "(wo = (2s, 2t, 1 - s^2 - t^2) / (1 + s^2 + t^2); i along x, j along y).");

  py::class_<Captures>(m, "Captures", "Hemisphere captures at points: frames, trees, lights.")
      .def(
          "__len__", [](const Captures& c) { return c.view.size(); }, "The number of captures.")
      .def_property_readonly(
          "positions", [](const Captures& c) { return vectors(c.view.positions); },
          "The points, N x 3 (a copy).")
      .def_property_readonly(
          "normals", [](const Captures& c) { return vectors(c.view.normals); },
          "The normals, N x 3 (a copy): each capture's frame has z along its normal.")
      .def_property_readonly(
          "tangents", [](const Captures& c) { return vectors(c.view.tangents); },
          "The tangents, N x 3 (a copy): each capture's frame has x along its tangent.")
      .def("tree", &capture_tree, py::arg("k"),
           "Capture k's radiance tree (negative k counts from the end; IndexError outside): the "
           "light it saw, less the compact lights it keeps apart (lights(k)), which shade() adds.")
      .def("__getitem__", &capture_tree, py::arg("k"), "Capture k's radiance tree, as tree(k).")
      .def(
          "lights",
          [](const Captures& c, long long k) {
            const std::size_t index = capture_index(c, k);
            py::list out;
            for (const DirectionalLight& l : c.view.lights_of(index))
              out.append(
                  py::make_tuple(py::make_tuple(l.direction.x(), l.direction.y(), l.direction.z()),
                                 py::make_tuple(l.energy[0], l.energy[1], l.energy[2])));
            return out;
          },
          py::arg("k"), "The lights capture k keeps apart: (direction in its frame, energy).");

  py::class_<File>(m, "File", "A loaded and verified .qt file (memory-mapped; trees in place).")
      .def_property_readonly(
          "kind", [](const File& f) { return to_string(f.file->kind()); },
          "'tree', 'brdf-table' or 'capture-set'.")
      .def_property_readonly(
          "format_version", [](const File& f) { return f.file->format_version(); },
          "The file's format version (older versions are read as well).")
      .def_property_readonly(
          "zero_copy", [](const File& f) { return f.file->zero_copy(); },
          "Whether the trees are read in place from the mapped file (False: restored into memory, "
          "as capture sets of format 7 and later are).")
      .def_property_readonly(
          "checksum_verified", [](const File& f) { return f.file->checksum_verified(); },
          "Whether the file carried the checksum of its bytes, which loading checked (format "
          "version 8 on; a file changed after it was written is refused).")
      .def_property_readonly(
          "provenance",
          [](const File& f) {
            const Provenance p = f.file->provenance();
            // File names need not be UTF-8: decoded as os.fsdecode does, so that they round-trip.
            auto fs_text = [](const std::string& text) {
              PyObject* decoded =
                  PyUnicode_DecodeFSDefaultAndSize(text.data(), Py_ssize_t(text.size()));
              if (!decoded) throw py::error_already_set();
              return py::reinterpret_steal<py::str>(decoded);
            };
            py::dict d;
            d["tool"] = fs_text(p.tool);
            d["tool_version"] = fs_text(p.tool_version);
            d["parameters"] = fs_text(p.parameters);
            py::list sources;
            for (const std::string& source : p.sources)
              sources.append(fs_text(source));
            d["sources"] = sources;
            return d;
          },
          "What made the file: tool, tool_version, parameters (JSON text) and sources (files; "
          "names that are not UTF-8 decoded as os.fsdecode does).")
      .def(
          "tree",
          [](const File& f) {
            if (f.file->kind() != QtKind::tree)
              throw FileError(f.file->name() + ": holds a " + to_string(f.file->kind()) +
                              ", not a single tree (table().entry(i, j) or captures().tree(k))");
            return Tree{f.file, f.file->tree(), f.file->projection()};
          },
          "The file's tree (a file of one tree).")
      .def(
          "table",
          [](const File& f) {
            // Written back, it names the same spec file and options, so that a measured
            // BRDF's data files are still found from it.
            const Provenance p = f.file->provenance();
            return Table{f.file,
                         f.file->brdf_table(),
                         f.file->brdf_model(),
                         f.file->brdf_spec(),
                         f.file->projection(),
                         f.file,
                         std::nullopt,
                         p.sources.empty() ? std::string() : p.sources.front(),
                         p.parameters.empty() ? std::string("{}") : p.parameters};
          },
          "The file's BRDF table (basis.Error for a file of another kind).")
      .def(
          "captures",
          [](const File& f) {
            return Captures{f.file, f.file->captures(), f.file->projection(), std::nullopt,
                            f.file->provenance()};
          },
          "The file's capture set (basis.Error for a file of another kind); written back, it "
          "keeps the file's provenance.");

  m.def(
      "load",
      [](const py::object& path_argument) {
        const std::string path = path_of(path_argument, "path");
        py::gil_scoped_release release;
        return File{std::make_shared<const QtFile>(QtFile::load(path))};
      },
      py::arg("path"),
      "Reads and verifies a .qt file; basis.Error names the file and the problem.");

  py::class_<PyBrdf>(m, "Brdf", "An analytic or measured BRDF, from a JSON spec (brdf2qt's).")
      .def_static(
          "from_file",
          [](const py::object& path_argument) {
            const std::string path = path_of(path_argument, "path");
            return PyBrdf{read_brdf_spec(path), path};
          },
          py::arg("path"),
          "A BRDF from a JSON spec file (brdf2qt's; README). basis.Error names the file and the "
          "problem.")
      .def_static(
          "from_json",
          [](const std::string& text) {
            // JSON text ends at its last character, not at a NUL the parser would stop at.
            if (text.find('\0') != std::string::npos)
              throw std::invalid_argument("spec text holds a NUL character");
            return PyBrdf{parse_brdf_spec(text, "spec", "."), ""};
          },
          py::arg("text"), "A BRDF from JSON spec text.")
      .def_property_readonly(
          "model", [](const PyBrdf& b) { return b.spec.model; }, "The model's name.")
      .def_property_readonly(
          "channels", [](const PyBrdf& b) { return channel_count(b.spec.brdf); },
          "1 when every colour of the spec is grey, else 3.")
      .def(
          "evaluate",
          [](const PyBrdf& b,
             const py::array_t<double, py::array::c_style | py::array::forcecast>& wi,
             const py::array_t<double, py::array::c_style | py::array::forcecast>& wo) {
            const std::vector<Vec3> i = to_vectors(wi, "wi"), o = to_vectors(wo, "wo");
            if (i.size() != o.size() && o.size() != 1)
              throw std::invalid_argument("wi and wo must hold as many directions (or wo one)");
            py::array_t<double> out({py::ssize_t(i.size()), py::ssize_t(3)});
            // The array's memory is written without the GIL; the array itself is not touched.
            auto a = out.mutable_unchecked<2>();
            {
              py::gil_scoped_release release;
              const std::vector<Vec3> unit_i = to_directions(i, "wi"),
                                      unit_o = to_directions(o, "wo");
              for (std::size_t k = 0; k < i.size(); ++k) {
                const Color f = evaluate(b.spec.brdf, unit_i[k], unit_o[o.size() == 1 ? 0 : k]);
                for (int c = 0; c < 3; ++c)
                  a(py::ssize_t(k), c) = f[c];
              }
            }
            return out;
          },
          py::arg("wi"), py::arg("wo"),
          "f(wi, wo) per channel for N x 3 arrays of directions in the local frame (z the normal).")
      .def_property_readonly(
          "lobe_width", [](const PyBrdf& b) { return lobe_width(b.spec.brdf); },
          "The lobe's angular width at normal incidence, in radians (its half width at half "
          "maximum over 1.1774); infinity without a lobe.")
      .def_property_readonly(
          "default_wo_resolution",
          [](const PyBrdf& b) { return default_wo_resolution(b.spec.brdf); },
          "The outgoing resolution M tabulate() takes by default for this BRDF (33 to 129).");

  m.def(
      "tabulate",
      [](const PyBrdf& b, std::optional<int> wo_res, std::optional<int> wi_res,
         std::optional<double> tolerance, double tolerance_floor, bool tilt, bool wo_derivatives,
         int threads) {
        // Arguments, else the spec's "table" block, else the defaults, as brdf2qt takes them.
        BrdfTableOptions options;
        options.wo_resolution =
            wo_res.value_or(b.spec.wo_resolution.value_or(default_wo_resolution(b.spec.brdf)));
        options.wi_resolution =
            wi_res.value_or(b.spec.wi_resolution.value_or(options.wi_resolution));
        options.projection.tolerance =
            tolerance.value_or(b.spec.tolerance.value_or(options.projection.tolerance));
        options.projection.local_floor = tolerance_floor;
        options.tilt_derivatives = tilt;
        options.wo_derivatives = wo_derivatives;
        // As brdf2qt warns, before any work and once the options are known to be valid:
        // resolutions too coarse for the lobe.
        check_table_options(options);
        const int arena_size = arena_threads(threads);
        warn_each(table_resolution_warnings(b.spec.brdf, options));
        BrdfTable table = run_interruptible([&](const TaskControl& control) {
          tbb::task_arena arena(arena_size);
          return arena.execute([&] {
            try {
              return tabulate_brdf(b.spec.brdf, options, control);
            } catch (const std::overflow_error& e) {
              if (b.source.empty()) throw;
              throw std::overflow_error(b.source + ": " + e.what());
            }
          });
        });
        table.spec = b.spec.text;
        Table out = own(std::move(table), options.projection);
        out.brdf = b.spec.brdf;
        out.source = b.source;
        out.parameters = table_parameters(options, b.spec.brdf);
        return out;
      },
      py::arg("brdf"), py::arg("wo_res") = py::none(), py::arg("wi_res") = py::none(),
      py::arg("tolerance") = py::none(), py::arg("tolerance_floor") = 0.2, py::arg("tilt") = true,
      py::arg("wo_derivatives") = true, py::arg("threads") = 0,
      "A BRDF table. Each option is the argument when given, else the spec's \"table\" block, else "
      "brdf2qt's default (outgoing resolution from the lobe's width, 128 texels, tolerance 5 %). "
      "Resolutions too coarse for the lobe are RuntimeWarnings, issued before the work; Ctrl-C "
      "stops it (KeyboardInterrupt).");

  m.def(
      "reflect",
      [](const Table& table, const Tree& radiance, const std::array<double, 3>& wo, double accuracy,
         const std::string& interpolation, bool bound) {
        const Vec3 direction = to_direction(to_vec3(wo), "wo");
        const LookupOptions options{{accuracy, bound}, interpolation_of(interpolation)};
        Convolution c;
        {
          py::gil_scoped_release release;
          c = reflect(table.view, radiance.view, direction, options);
        }
        return result(c);
      },
      py::arg("table"), py::arg("radiance"), py::arg("wo") = std::array<double, 3>{0, 0, 1},
      py::arg("accuracy") = 0.0, py::arg("interpolation") = "hermite", py::arg("bound") = true,
      "Reflected radiance towards wo (pi included) of one radiance tree, and its bound (inf with "
      "bound=False: the same value, faster). A capture's tree leaves out the compact lights the "
      "capture keeps apart (Captures.lights): shade() adds them. Hermite interpolation needs "
      "the table's derivatives over wo; without them (has_wo_derivatives) lookups are bilinear. "
      "Between entries it descends each entry around wo on its own, where shade() and "
      "qtconvolve fold them into one tree once for their batch (the sum rounded to halves, the "
      "bounds charged entry by entry): the values then differ by up to about 1e-3 relative and "
      "the bounds by up to about 15 %, either way, each holding.");

  m.def(
      "reflect_tilted",
      [](const Table& table, const Tree& radiance, const std::array<double, 3>& wo,
         const std::array<double, 2>& tilt, const std::string& mode, double accuracy,
         const std::string& interpolation, bool bound) {
        const TiltCompensation compensation =
            mode == "none"             ? TiltCompensation::none
            : mode == "reparametrised" ? TiltCompensation::reparametrised
            : mode == "compensated"    ? TiltCompensation::compensated
                                       : throw std::invalid_argument(
                                             "mode must be 'none', 'reparametrised' or "
                                                "'compensated', got '" +
                                             mode + "'");
        const Vec3 direction = to_direction(to_vec3(wo), "wo");
        const LookupOptions options{{accuracy, bound}, interpolation_of(interpolation)};
        Convolution c;
        {
          py::gil_scoped_release release;
          c = reflect_tilted(table.view, radiance.view, direction, {tilt[0], tilt[1]}, compensation,
                             options);
        }
        return result(c);
      },
      py::arg("table"), py::arg("radiance"), py::arg("wo"), py::arg("tilt"),
      py::arg("mode") = "compensated", py::arg("accuracy") = 0.0,
      py::arg("interpolation") = "hermite", py::arg("bound") = true,
      "Reflected radiance at a surface tilted by the rotation vector tilt = (x, y) (radians, in "
      "the record's tangent plane) against the frame the radiance was recorded in; wo in the "
      "tilted frame. accuracy, interpolation and bound as reflect's (qtconvolve --normal with "
      "--accuracy, --interpolation, --no-bound).");

  m.def(
      "shade",
      [](const Table& table, const Captures& captures, const std::array<double, 3>& wo,
         double accuracy, const std::string& interpolation, bool bound) {
        ShadingOptions options;
        options.wo = to_direction(to_vec3(wo), "wo");
        // Only lights need the BRDF: it is rebuilt (a measured one's data file read) only then.
        const Brdf* brdf = captures.view.lights.empty() ? nullptr : table_brdf_of(table);
        options.light_brdf = brdf;
        options.convolution.accuracy = accuracy;
        options.convolution.bound = bound;
        options.interpolation = interpolation_of(interpolation);
        // One wo for every capture: the entries around it are found and folded once.
        const EntriesAtWo entries =
            entries_at(table.view, options.wo, options.interpolation,
                       /*with_texels=*/!brdf && !captures.view.lights.empty());
        const std::size_t n = captures.view.size();
        py::array_t<double> values({py::ssize_t(n), py::ssize_t(3)}),
            bounds({py::ssize_t(n), py::ssize_t(3)});
        double* v = values.mutable_data();
        double* b = bounds.mutable_data();
        {
          py::gil_scoped_release release;
          for (std::size_t k = 0; k < n; ++k) {
            const Convolution c = shade(table.view, entries, captures.view, k, options);
            for (int ch = 0; ch < 3; ++ch) {
              v[3 * k + ch] = c.value[ch];
              b[3 * k + ch] = c.bound[ch];
            }
          }
        }
        return py::make_tuple(values, bounds);
      },
      py::arg("table"), py::arg("captures"), py::arg("wo") = std::array<double, 3>{0, 0, 1},
      py::arg("accuracy") = 0.0, py::arg("interpolation") = "hermite", py::arg("bound") = true,
      "Reflected radiance towards wo (each capture's frame) at every capture, with the lights "
      "it keeps apart shaded by the table's BRDF (rebuilt from its spec once per table, when "
      "there are lights; the table's texels, with a RuntimeWarning, when that fails): (values, "
      "bounds), N x 3 arrays. What qtconvolve TABLE CAPTURES "
      "prints. bound=False: the same values, faster, and bounds of inf (qtconvolve "
      "--no-bound).");

  m.def(
      "capture",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& points,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& normals,
         const py::object& env_argument, std::optional<std::array<double, 3>> constant,
         const py::object& scene_argument, int res, int spp, double tolerance, std::uint64_t seed,
         bool splat_lights, bool zero_invalid, int threads) {
        const std::string env = env_argument.is_none() ? "" : path_of(env_argument, "env"),
                          scene = scene_argument.is_none() ? "" : path_of(scene_argument, "scene");
        const std::vector<Vec3> p = to_vectors(points, "points"),
                                n = to_vectors(normals, "normals");
        if (p.size() != n.size()) throw std::invalid_argument("as many normals as points");
        if (!env.empty() && constant)
          throw std::invalid_argument("env and constant exclude each other: give one light");
        if (env.empty() && !constant)
          throw std::invalid_argument("give the light: env=PATH or constant=(r, g, b)");
        if (spp < 1 || spp > 4096)
          throw std::invalid_argument("spp must be a square number from 1 to 4096, got " +
                                      std::to_string(spp));
        const int strata = int(std::lround(std::sqrt(spp)));
        if (strata * strata != spp) throw std::invalid_argument("spp must be a square number");
        if (!is_valid_resolution(res))
          throw std::invalid_argument("res must be a power of two from 2 to 512");
        const int arena_size = arena_threads(threads);
        std::vector<SurfacePoint> surface;
        for (std::size_t k = 0; k < p.size(); ++k) {
          surface.push_back({p[k], to_direction(n[k], "normals[" + std::to_string(k) + "]")});
        }
        CaptureRecipe recipe;
        recipe.environment = env;
        if (constant) recipe.constant = {(*constant)[0], (*constant)[1], (*constant)[2]};
        recipe.scene = scene;
        recipe.projection.tolerance = tolerance;
        check_projection_options(recipe.projection);
        // The provenance can name the inputs: refused before any work, as capture2qt does.
        static_cast<void>(capture_parameters(recipe));
        // The map and the scene, read without the GIL; what they repaired, warned of after.
        std::unique_ptr<TriangleMesh> mesh;
        std::unique_ptr<EmbreeScene> traced;
        std::unique_ptr<Environment> environment;
        std::vector<std::string> warnings;
        {
          py::gil_scoped_release release;
          environment =
              std::make_unique<Environment>(env.empty() ? Environment::constant(recipe.constant)
                                                        : Environment(read_image(env), 0, env));
          const std::string repaired = repaired_texels_warning(
              *environment, zero_invalid,
              "repair the map, or pass zero_invalid=True to read them as 0");
          if (!repaired.empty()) warnings.push_back(repaired);
          if (!scene.empty()) {
            mesh = std::make_unique<TriangleMesh>(read_obj(scene));
            if (mesh->dropped_degenerate > 0)
              warnings.push_back(scene + ": " + std::to_string(mesh->dropped_degenerate) +
                                 " degenerate triangles dropped");
            warnings.insert(warnings.end(), mesh->reader_warnings.begin(),
                            mesh->reader_warnings.end());
            traced = std::make_unique<EmbreeScene>(*mesh);
          }
          recipe.inputs_checksum = capture_inputs_checksum(*environment, mesh.get());
        }
        warn_each(warnings);
        recipe.options = {.resolution = res,
                          .strata = strata,
                          .seed = seed,
                          .ray_offset = mesh ? mesh->ray_offset() : 1e-4,
                          .compact_lights = splat_lights ? CaptureOptions::CompactLights::splatted
                                                         : CaptureOptions::CompactLights::apart};
        CaptureSetOptions options;
        options.capture = recipe.options;
        options.projection = recipe.projection;
        auto set =
            std::make_shared<const CaptureSet>(run_interruptible([&](const TaskControl& control) {
              tbb::task_arena arena(arena_size);
              return arena.execute([&] {
                return capture_set(*environment, traced.get(), surface, options, control);
              });
            }));
        return Captures{set, set->view(), recipe.projection, recipe, std::nullopt};
      },
      py::arg("points"), py::arg("normals"), py::arg("env") = py::none(),
      py::arg("constant") = py::none(), py::arg("scene") = py::none(), py::arg("res") = 128,
      py::arg("spp") = 4, py::arg("tolerance") = 0.05, py::arg("seed") = 1,
      py::arg("splat_lights") = false, py::arg("zero_invalid") = false, py::arg("threads") = 0,
      "Captures at points (N x 3) with normals (N x 3), lit by a lat-long map (env) or a constant, "
      "occluded by an OBJ scene: what capture2qt --points makes, with the same defaults. A map "
      "with NaN or infinite texels is a basis.Error unless zero_invalid=True reads them as 0 "
      "(capture2qt --zero-invalid); texels read as 0, degenerate triangles dropped and "
      "material files the scene names but that cannot be found are RuntimeWarnings. Ctrl-C stops "
      "the work (KeyboardInterrupt).");

  m.def(
      "write",
      [](const py::object& path_argument, const py::object& what) {
        const std::string path = path_of(path_argument, "path");
        // Encoding and writing run without the GIL; `what` keeps the object alive meanwhile.
        std::function<std::vector<std::byte>()> encode;
        if (py::isinstance<Table>(what)) {
          const Table& t = what.cast<const Table&>();
          encode = [&t] {
            return encode_brdf_table(t.view, t.model, t.spec, t.projection,
                                     python_provenance(t.parameters, t.source));
          };
        } else if (py::isinstance<Captures>(what)) {
          const Captures& c = what.cast<const Captures&>();
          encode = [&c] {
            return encode_capture_set(c.view, c.projection, captures_provenance(c));
          };
        } else if (py::isinstance<Tree>(what)) {
          const Tree& t = what.cast<const Tree&>();
          encode = [&t] { return encode_tree(t.view, t.projection, python_provenance()); };
        } else {
          throw py::type_error("write takes a Table, Captures or Tree, got " +
                               std::string(py::str(py::type::of(what).attr("__name__"))));
        }
        py::gil_scoped_release release;
        write_qt(path, encode());
      },
      py::arg("path"), py::arg("what"),
      "Writes a table, capture set or tree as a .qt file (atomically; verified as the reader "
      "verifies it).");

  for (const char* name : {"Tree", "Table", "Captures", "File", "Brdf"})
    refuse_bare_new(m.attr(name));
}

}  // namespace basis::python
