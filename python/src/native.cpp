// tracemesh._native: the C++ half of the Python package (python/tracemesh/__init__.py is the public half). It reads
// molecules, meshes them and encodes meshes with the functions the CLI uses (read_molecule_file, parse_mesh_params,
// mesh_molecule, report_to_json, the encoders and cli/options.hpp's format rules), so that the same call gives the
// same bytes as `tracemesh`. Failures are raised as the package's exceptions (tracemesh._errors.raise_status).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli/atomic_file.hpp"
#include "cli/options.hpp"
#include "core/io/atom_checks.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "core/mesher.hpp"
#include "proto/api_types.hpp"
#include "proto/mesh_encoders.hpp"
#include "proto/report_json.hpp"

namespace py = pybind11;

namespace tracemesh::python {
namespace {

/// How often a waiting mesh() looks for a pending signal (Ctrl-C) and passes progress on: often enough that an
/// interrupt feels immediate, rarely enough that waiting costs nothing next to meshing.
constexpr std::chrono::milliseconds signal_poll_interval{50};

using field_texts = std::map<std::string, std::string, std::less<>>;
using float_array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using index_array = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

/// Raises `error` as the package's exception for its code (ValueError for invalid_argument).
[[noreturn]] void raise_status(const status& error) {
  py::module_::import("tracemesh._errors").attr("raise_status")(errc_name(error.code()), error.message());
  throw std::logic_error("tracemesh._errors.raise_status returned");  // it always raises
}

template <class T>
T value_or_raise(result<T> outcome) {
  if (!outcome) raise_status(outcome.error());
  return std::move(outcome).value();
}

proto::field_lookup lookup_in(const field_texts& texts) {
  return [&texts](std::string_view name) -> std::optional<std::string> {
    const auto found = texts.find(name);
    if (found == texts.end()) return std::nullopt;
    return found->second;
  };
}

/// A (rows × columns) float64 array holding `values` row by row.
float_array rows_of(std::vector<double> values, py::ssize_t columns) {
  const py::ssize_t rows = columns == 0 ? 0 : static_cast<py::ssize_t>(values.size()) / columns;
  float_array array(columns == 1 ? std::vector<py::ssize_t>{rows} : std::vector<py::ssize_t>{rows, columns});
  std::copy(values.begin(), values.end(), array.mutable_data());
  return array;
}

py::array_t<std::int32_t> int32_rows(const std::vector<std::uint32_t>& values, py::ssize_t columns) {
  const py::ssize_t rows = static_cast<py::ssize_t>(values.size()) / columns;
  py::array_t<std::int32_t> array(columns == 1 ? std::vector<py::ssize_t>{rows}
                                               : std::vector<py::ssize_t>{rows, columns});
  std::int32_t* out = array.mutable_data();
  for (std::size_t i = 0; i < values.size(); ++i) out[i] = static_cast<std::int32_t>(values[i]);
  return array;
}

// ---- read_molecule ----------------------------------------------------------------------------------------------

py::dict read_molecule(const std::string& path, const field_texts& options) {
  const structure_options input = value_or_raise(parse_structure_options(lookup_in(options)));
  std::optional<result<read_molecule_result>> read;
  {
    py::gil_scoped_release unlocked;
    const std::string file_name = std::filesystem::path(path).filename().string();
    read.emplace(read_molecule_file(path, declared_by_file_name(file_name, input), mesh_limits{}));
  }
  const read_molecule_result molecule_read = value_or_raise(std::move(*read));
  std::vector<double> positions, radii, charges;
  for (const atom& a : molecule_read.mol.atoms) {
    positions.insert(positions.end(), {a.center.x, a.center.y, a.center.z});
    radii.push_back(a.radius);
    charges.push_back(a.charge);
  }
  py::dict out;
  out["positions"] = rows_of(std::move(positions), 3);
  out["radii"] = rows_of(std::move(radii), 1);
  out["charges"] = rows_of(std::move(charges), 1);
  out["input"] = proto::summarize_input(molecule_read);
  return out;
}

// ---- mesh ----------------------------------------------------------------------------------------------------------

/// The atoms of positions (N×3) and radii (N), checked as the readers check a file's atoms.
molecule molecule_of(const float_array& positions, const float_array& radii, const mesh_limits& limits) {
  if (positions.ndim() != 2 || positions.shape(1) != 3) {
    raise_status({errc::invalid_argument, "positions must be an array of shape (N, 3)"});
  }
  const py::ssize_t count = positions.shape(0);
  if (radii.ndim() != 1 || radii.shape(0) != count) {
    raise_status({errc::invalid_argument, "radii must be an array of shape (N,) with N = " + std::to_string(count)});
  }
  if (static_cast<std::size_t>(count) > limits.max_atoms) {
    raise_status({errc::limit_exceeded, std::to_string(count) + " atoms exceed the limit of " +
                                            std::to_string(limits.max_atoms) + " (limits.max_atoms)"});
  }
  molecule mol;
  mol.atoms.reserve(static_cast<std::size_t>(count));
  const double* xyz = positions.data();
  const double* r = radii.data();
  for (py::ssize_t i = 0; i < count; ++i) {
    const atom a{{xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]}, r[i], 0.0};
    if (const std::string problem = detail::atom_range_problem(a, limits); !problem.empty()) {
      raise_status({errc::invalid_argument, "atom " + std::to_string(i) + ": " + problem});
    }
    detail::add_atom(mol, a);
  }
  if (const status something = detail::check_something_to_mesh(mol, "atoms"); !something) raise_status(something);
  return mol;
}

/// One mesh_molecule run on its own thread, while the calling (Python) thread waits for it with the GIL released,
/// waking every signal_poll_interval: Python runs signal handlers only on its main thread and only when asked.
class meshing_run {
 public:
  meshing_run(const molecule& mol, const mesh_params& params, bool hold_until_cancelled)
      : hold_until_cancelled_(hold_until_cancelled),
        token_([this](mesh_stage stage, double fraction) { on_progress(stage, fraction); }),
        worker_([this, &mol, params] {
          result<mesh_output> meshed = run_mesher(mol, params);
          std::lock_guard lock(mutex_);
          outcome_.emplace(std::move(meshed));
          changed_.notify_all();
        }) {}
  meshing_run(const meshing_run&) = delete;
  meshing_run& operator=(const meshing_run&) = delete;
  ~meshing_run() { stop(); }

  /// Waits until the run ends, calling `on_progress` (stage name, fraction) with the GIL held as progress comes.
  /// A signal handler or `on_progress` that raises cancels the run, and the exception propagates once it stopped.
  result<mesh_output> wait(const py::object& on_progress) {
    progress_report passed_on;
    for (;;) {
      progress_report latest;
      bool finished = false;
      {
        py::gil_scoped_release unlocked;
        std::unique_lock lock(mutex_);
        changed_.wait_for(lock, signal_poll_interval, [&] { return outcome_.has_value() || latest_ != passed_on; });
        latest = latest_;
        finished = outcome_.has_value();
      }
      try {
        if (latest.reports > passed_on.reports && !on_progress.is_none()) {
          on_progress(stage_name(latest.stage), latest.fraction);
        }
        passed_on = latest;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      } catch (...) {
        stop();
        throw;
      }
      if (finished) break;
    }
    stop();
    return std::move(*outcome_);
  }

 private:
  /// The last progress report, and how many came so far (so that a repeated fraction still counts as news).
  struct progress_report {
    mesh_stage stage = mesh_stage::reading;
    double fraction = 0;
    std::size_t reports = 0;
    bool operator==(const progress_report&) const = default;
  };

  /// mesh_molecule, whose exceptions (out of memory) become an error: one escaping this thread would end Python.
  result<mesh_output> run_mesher(const molecule& mol, const mesh_params& params) {
    try {
      return mesh_molecule(mol, params, mesh_limits{}, token_);
    } catch (const std::exception& error) {
      return status(errc::internal_error, std::string("internal error: ") + error.what());
    }
  }

  void on_progress(mesh_stage stage, double fraction) {
    std::unique_lock lock(mutex_);
    latest_ = {stage, fraction, latest_.reports + 1};
    changed_.notify_all();
    // The test seam: the run holds here, reporting its first stage, until it is cancelled.
    if (hold_until_cancelled_) changed_.wait(lock, [this] { return token_.cancelled(); });
  }

  /// Cancels the run if it is still going and joins its thread, with the GIL released (the run never takes it).
  void stop() {
    if (!worker_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      token_.cancel();
      changed_.notify_all();
    }
    py::gil_scoped_release unlocked;
    worker_.join();
  }

  const bool hold_until_cancelled_;
  std::mutex mutex_;
  std::condition_variable changed_;
  progress_report latest_;  ///< guarded by mutex_, as outcome_
  std::optional<result<mesh_output>> outcome_;
  progress_token token_;
  std::thread worker_;  ///< last: starts once everything it uses exists
};

py::dict mesh(const float_array& positions, const float_array& radii, const field_texts& fields, unsigned threads,
              const std::optional<proto::input_summary>& input, const py::object& on_progress,
              bool hold_until_cancelled) {
  mesh_params params = value_or_raise(proto::parse_mesh_params(lookup_in(fields)));
  if (threads > cli::max_threads) {
    raise_status({errc::invalid_argument, "threads must be an integer in [0, " + std::to_string(cli::max_threads) +
                                              "] (0 = all cores), got " + std::to_string(threads)});
  }
  params.threads = threads;
  const molecule mol = molecule_of(positions, radii, mesh_limits{});

  mesh_output output = [&] {
    meshing_run run(mol, params, hold_until_cancelled);
    return value_or_raise(run.wait(on_progress));
  }();
  const surface_mesh& m = output.mesh;
  std::vector<double> vertices, normals;
  std::vector<std::uint32_t> faces;
  for (const vec3& p : m.positions) vertices.insert(vertices.end(), {p.x, p.y, p.z});
  for (const vec3& n : m.normals) normals.insert(normals.end(), {n.x, n.y, n.z});
  for (const auto& t : m.triangles) faces.insert(faces.end(), t.begin(), t.end());
  py::dict out;
  out["vertices"] = rows_of(std::move(vertices), 3);
  out["faces"] = int32_rows(faces, 3);
  out["normals"] = rows_of(std::move(normals), 3);
  out["atom_index"] = int32_rows(m.atom_index, 1);
  out["report"] = proto::report_to_json(output, params, input).dump();
  out["fallback_reason"] = output.fallback_reason;
  return out;
}

// ---- encode and save ----------------------------------------------------------------------------------------------

/// The mesh of the arrays, checked so that no encoder sees an index or a per-vertex array that does not fit.
surface_mesh mesh_of(const float_array& vertices, const index_array& faces, const float_array& normals,
                     const index_array& atom_index) {
  if (vertices.ndim() != 2 || vertices.shape(1) != 3) {
    raise_status({errc::invalid_argument, "vertices must be an array of shape (V, 3)"});
  }
  if (faces.ndim() != 2 || faces.shape(1) != 3) {
    raise_status({errc::invalid_argument, "faces must be an array of shape (F, 3)"});
  }
  const py::ssize_t count = vertices.shape(0);
  const bool normals_fit = normals.size() == 0 || (normals.ndim() == 2 && normals.shape(0) == count &&
                                                   normals.shape(1) == 3);
  if (!normals_fit) raise_status({errc::invalid_argument, "normals must be empty or of shape (V, 3)"});
  if (!(atom_index.size() == 0 || (atom_index.ndim() == 1 && atom_index.shape(0) == count))) {
    raise_status({errc::invalid_argument, "atom_index must be empty or of shape (V,)"});
  }
  surface_mesh m;
  const double* xyz = vertices.data();
  for (py::ssize_t i = 0; i < count; ++i) m.positions.push_back({xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
  const double* n = normals.data();
  for (py::ssize_t i = 0; i < normals.shape(0) && normals.size() != 0; ++i) {
    m.normals.push_back({n[3 * i], n[3 * i + 1], n[3 * i + 2]});
  }
  const std::int64_t* corners = faces.data();
  for (py::ssize_t f = 0; f < faces.shape(0); ++f) {
    std::array<std::uint32_t, 3> triangle{};
    for (int k = 0; k < 3; ++k) {
      const std::int64_t corner = corners[3 * f + k];
      if (corner < 0 || corner >= count) {
        raise_status({errc::invalid_argument, "face " + std::to_string(f) + " has vertex index " +
                                                  std::to_string(corner) + ", not in [0, " + std::to_string(count) +
                                                  ")"});
      }
      triangle[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(corner);
    }
    m.triangles.push_back(triangle);
  }
  const std::int64_t* atoms = atom_index.data();
  for (py::ssize_t i = 0; i < atom_index.size(); ++i) {
    if (atoms[i] < 0 || atoms[i] > UINT32_MAX) {
      raise_status({errc::invalid_argument, "atom_index " + std::to_string(atoms[i]) + " is not a uint32"});
    }
    m.atom_index.push_back(static_cast<std::uint32_t>(atoms[i]));
  }
  return m;
}

/// The encoded mesh: one buffer per file (two for MSMS), as the CLI encodes (cli/run.cpp).
std::vector<std::string> encoded(const surface_mesh& m, cli::output_format format) {
  if (format.msms) return {proto::encode_msms_vert(m), proto::encode_msms_face(m)};
  const proto::encoder_input input(m);
  return {value_or_raise(proto::format_info(format.mesh).encode(input))};
}

std::vector<py::bytes> encode(const float_array& vertices, const index_array& faces, const float_array& normals,
                              const index_array& atom_index, const std::string& format_name) {
  const cli::output_format format = value_or_raise(cli::parse_output_format(format_name));
  const surface_mesh m = mesh_of(vertices, faces, normals, atom_index);
  std::vector<std::string> buffers;
  {
    py::gil_scoped_release unlocked;
    buffers = encoded(m, format);
  }
  return {buffers.begin(), buffers.end()};
}

/// Writes the mesh as `tracemesh -o path [--format format]` does; the paths written.
std::vector<std::string> save(const float_array& vertices, const index_array& faces, const float_array& normals,
                              const index_array& atom_index, const std::string& path,
                              const std::optional<std::string>& format_name) {
  const cli::output_format format =
      value_or_raise(format_name ? cli::parse_output_format(*format_name) : cli::infer_output_format(path));
  const surface_mesh m = mesh_of(vertices, faces, normals, atom_index);
  const std::vector<std::filesystem::path> paths = cli::output_paths(path, format);
  status written;
  {
    py::gil_scoped_release unlocked;
    const std::vector<std::string> buffers = encoded(m, format);
    std::vector<cli::file_contents> files;
    for (std::size_t i = 0; i < paths.size() && i < buffers.size(); ++i) files.push_back({paths[i], buffers[i]});
    written = cli::write_files_atomically(files);
  }
  if (!written) raise_status(written);
  return {paths.begin(), paths.end()};
}

std::vector<std::string> names(auto&& list) { return {list.begin(), list.end()}; }

}  // namespace
}  // namespace tracemesh::python

PYBIND11_MODULE(_native, module) {
  using namespace tracemesh::python;
  namespace proto = tracemesh::proto;
  module.doc() = "The C++ half of the tracemesh package: use the functions of `tracemesh` instead.";
  module.attr("engine_version") = tracemesh::engine_version;
  module.attr("mesh_parameter_fields") = names(proto::mesh_parameter_fields);
  module.attr("structure_option_names") = names(tracemesh::structure_option_names);
  module.attr("max_threads") = tracemesh::cli::max_threads;
  std::vector<std::string> formats;
  for (const proto::mesh_format_info& info : proto::mesh_formats()) formats.emplace_back(info.name);
  formats.emplace_back("msms");
  module.attr("output_formats") = formats;
  py::class_<proto::input_summary>(module, "InputSummary", "What read_molecule read, for the report's input.")
      .def_property_readonly("format",
                             [](const proto::input_summary& input) { return tracemesh::input_format_name(input.format); })
      .def_property_readonly("radii", [](const proto::input_summary& input) { return input.radii; })
      .def_property_readonly("json", [](const proto::input_summary& input) { return proto::input_to_json(input).dump(); });
  module.def("read_molecule", &read_molecule, py::arg("path"), py::arg("options"));
  module.def("mesh", &mesh, py::arg("positions"), py::arg("radii"), py::arg("fields"), py::arg("threads"),
             py::arg("input"), py::arg("on_progress"), py::arg("hold_until_cancelled"));
  module.def("encode", &encode, py::arg("vertices"), py::arg("faces"), py::arg("normals"), py::arg("atom_index"),
             py::arg("format"));
  module.def("save", &save, py::arg("vertices"), py::arg("faces"), py::arg("normals"), py::arg("atom_index"),
             py::arg("path"), py::arg("format"));
}
