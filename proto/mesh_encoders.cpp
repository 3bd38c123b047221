#include "proto/mesh_encoders.hpp"
#include "proto/mesh_format.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>
#include <system_error>

#include <tiny_gltf.h>

#include "core/analysis/mesh_analysis.hpp"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"

namespace tracemesh::proto {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Text helpers: std::to_chars is locale-free and exact, unlike printf/iostreams under a user locale.

void append_general(std::string& out, double value, int significant_digits) {
  char buffer[64];
  if (value == 0) value = 0;  // print -0 as 0
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general,
                                     significant_digits);
  out.append(buffer, written.ptr);
}

void append_fixed(std::string& out, double value, int decimals) {
  char buffer[400];  // the longest fixed-notation double (≈ 1.8e308) fits
  if (value == 0) value = 0;
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
  if (written.ec == std::errc{}) {
    out.append(buffer, written.ptr);
  } else {
    append_general(out, value, 17);
  }
}

void append_integer(std::string& out, std::uint64_t value) {
  char buffer[24];
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, written.ptr);
}

/// OFF keeps 1e-6 Å resolution wherever the mesh is: 9 significant digits up to ±1000 Å, one more per decade.
int off_significant_digits(const surface_mesh& mesh) {
  double max_magnitude = 0;
  for (const vec3& p : mesh.positions) {
    max_magnitude = std::max({max_magnitude, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  }
  int digits = 9;
  for (double limit = 1000; max_magnitude >= limit && digits < 17; limit *= 10) ++digits;
  return digits;
}
constexpr int msms_decimals = 6;

double triangle_area(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const std::size_t n = mesh.positions.size();
  if (t[0] >= n || t[1] >= n || t[2] >= n) return 0;
  const vec3& a = mesh.positions[t[0]];
  return 0.5 * norm(cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a));
}

/// Header line 3 shared by .vert and .face: "<count> <spheres> <density> <probe radius>".
std::string msms_counts_line(const surface_mesh& mesh, std::size_t count) {
  std::uint64_t spheres = 0;
  for (const std::uint32_t atom : mesh.atom_index) spheres = std::max<std::uint64_t>(spheres, atom + 1ULL);
  double area = 0;
  for (const auto& t : mesh.triangles) area += triangle_area(mesh, t);
  const double density = area > 0 ? static_cast<double>(mesh.vertex_count()) / area : 0.0;
  std::string line;
  append_integer(line, count);
  line += ' ';
  append_integer(line, spheres);
  line += ' ';
  append_fixed(line, density, 4);
  line += " 0.0\n";
  return line;
}

// ---------------------------------------------------------------------------------------------------------------
// Draco

/// Distance from |x| to the next float32 up: the float rounding step of values of magnitude |x|.
double float_ulp(double x) {
  const float f = static_cast<float>(std::fabs(x));
  return static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity())) - static_cast<double>(f);
}

/// The preconditions every binary encoder shares (`what` names the format in messages).
status check_encoder_input(const surface_mesh& mesh, const std::string& what) {
  const std::size_t n = mesh.vertex_count();
  if (n == 0 || mesh.triangle_count() == 0) {
    return {errc::invalid_argument, what + ": the mesh has no triangle"};
  }
  if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) ||
      mesh.triangle_count() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    return {errc::limit_exceeded, what + ": more than 2^31 vertices or triangles"};
  }
  if (!mesh.normals.empty() && mesh.normals.size() != n) {
    return {errc::invalid_argument, what + ": normals must have one entry per vertex"};
  }
  if (!mesh.atom_index.empty() && mesh.atom_index.size() != n) {
    return {errc::invalid_argument, what + ": atom_index must have one entry per vertex"};
  }
  for (const auto& t : mesh.triangles) {
    if (t[0] >= n || t[1] >= n || t[2] >= n) {
      return {errc::invalid_argument, what + ": a triangle refers to a vertex past the end"};
    }
  }
  for (const vec3& p : mesh.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return {errc::invalid_argument, what + ": non-finite vertex coordinate"};
    }
  }
  for (const auto& normal : mesh.normals) {
    if (!std::isfinite(normal.x) || !std::isfinite(normal.y) || !std::isfinite(normal.z)) {
      return {errc::invalid_argument, what + ": non-finite normal"};
    }
  }
  return status::success();
}

template <class T, std::size_t components>
void add_attribute(draco::Mesh& target, draco::GeometryAttribute::Type type, draco::DataType data_type,
                   const std::vector<std::array<T, components>>& values, std::uint32_t unique_id) {
  auto attribute = std::make_unique<draco::PointAttribute>();
  attribute->Init(type, static_cast<std::int8_t>(components), data_type, false, values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    attribute->SetAttributeValue(draco::AttributeValueIndex(static_cast<std::uint32_t>(i)), values[i].data());
  }
  const int id = target.AddAttribute(std::move(attribute));
  target.attribute(id)->set_unique_id(unique_id);
}

/// A per-vertex integer as a named GENERIC int32 Draco attribute.
void add_named_int_attribute(draco::Mesh& target, const std::vector<std::int32_t>& per_vertex, std::uint32_t unique_id,
                             const char* name) {
  std::vector<std::array<std::int32_t, 1>> values(per_vertex.size());
  for (std::size_t i = 0; i < per_vertex.size(); ++i) values[i][0] = per_vertex[i];
  add_attribute(target, draco::GeometryAttribute::GENERIC, draco::DT_INT32, values, unique_id);
  const int id = target.num_attributes() - 1;
  auto metadata = std::make_unique<draco::AttributeMetadata>();
  metadata->AddEntryString("name", name);
  target.AddAttributeMetadata(id, std::move(metadata));
}

/// The mesh as Draco's structure, attributes mapped one value per point (no deduplication, no seams).
std::unique_ptr<draco::Mesh> to_draco_mesh(const surface_mesh& mesh, const std::vector<std::int32_t>& components) {
  auto target = std::make_unique<draco::Mesh>();
  const std::size_t n = mesh.vertex_count();
  target->set_num_points(static_cast<std::uint32_t>(n));
  target->SetNumFaces(mesh.triangle_count());
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f) {
    const auto& t = mesh.triangles[f];
    target->SetFace(draco::FaceIndex(static_cast<std::uint32_t>(f)),
                    {draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  std::vector<std::array<float, 3>> positions(n);
  std::transform(mesh.positions.begin(), mesh.positions.end(), positions.begin(), to_float3);
  add_attribute(*target, draco::GeometryAttribute::POSITION, draco::DT_FLOAT32, positions, 0);
  if (!mesh.normals.empty()) {
    std::vector<std::array<float, 3>> normals(n);
    std::transform(mesh.normals.begin(), mesh.normals.end(), normals.begin(), to_float3);
    add_attribute(*target, draco::GeometryAttribute::NORMAL, draco::DT_FLOAT32, normals, 1);
  }
  if (!mesh.atom_index.empty()) {
    // Atom counts are capped far below 2^31 (mesh_limits::max_atoms); the cast keeps the bits regardless.
    std::vector<std::int32_t> atoms(n);
    std::transform(mesh.atom_index.begin(), mesh.atom_index.end(), atoms.begin(),
                   [](std::uint32_t atom) { return static_cast<std::int32_t>(atom); });
    add_named_int_attribute(*target, atoms, draco_settings::atom_index_unique_id, "atom_index");
  }
  add_named_int_attribute(*target, components, draco_settings::component_unique_id, "component");
  return target;
}


/// Encodes `mesh` (already in Draco's structure) on `grid`.
result<std::string> draco_bytes(const draco::Mesh& mesh, const position_quantization& grid) {
  draco::Encoder encoder;
  encoder.SetSpeedOptions(draco_settings::encoding_speed, draco_settings::decoding_speed);
  encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, grid.bits, 3, grid.origin, grid.range);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, draco_settings::normal_bits);
  draco::EncoderBuffer buffer;
  const draco::Status encoded = encoder.EncodeMeshToBuffer(mesh, &buffer);
  if (!encoded.ok()) return status(errc::internal_error, std::string("draco: ") + encoded.error_msg_string());
  return std::string(buffer.data(), buffer.size());
}

/// One value per point of a decoded 1-component attribute, or an empty vector when the attribute is missing.
std::vector<std::int32_t> int_attribute_values(const draco::Mesh& mesh, std::uint32_t unique_id) {
  const draco::PointAttribute* attribute = mesh.GetAttributeByUniqueId(unique_id);
  if (!attribute || attribute->num_components() != 1) return {};
  std::vector<std::int32_t> values(mesh.num_points());
  for (draco::PointIndex p(0); p < mesh.num_points(); ++p) {
    attribute->ConvertValue<std::int32_t, 1>(attribute->mapped_index(p), &values[p.value()]);
  }
  return values;
}

std::vector<vec3> vec3_attribute_values(const draco::PointAttribute& attribute, std::uint32_t points) {
  std::vector<vec3> values(points);
  for (draco::PointIndex p(0); p < points; ++p) {
    std::array<float, 3> value{};
    attribute.ConvertValue<float, 3>(attribute.mapped_index(p), value.data());
    values[p.value()] = {value[0], value[1], value[2]};
  }
  return values;
}

std::size_t count_coincident_vertices(const std::vector<vec3>& positions) {
  std::vector<std::uint32_t> order(positions.size());
  std::iota(order.begin(), order.end(), 0U);
  const auto key = [&](std::uint32_t v) { return std::tuple(positions[v].x, positions[v].y, positions[v].z); };
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::size_t coincident = 0;
  for (std::size_t i = 1; i < order.size(); ++i) coincident += key(order[i]) == key(order[i - 1]) ? 1 : 0;
  return coincident;
}

/// The mesh with its coordinates rounded to float32, as glb-raw and ply carry them.
surface_mesh rounded_to_float32(const surface_mesh& mesh) {
  surface_mesh rounded;
  rounded.positions.reserve(mesh.vertex_count());
  for (const vec3& p : mesh.positions) {
    rounded.positions.push_back({static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
  }
  rounded.triangles = mesh.triangles;
  return rounded;
}

std::string describe(const delivered_check& check) {
  return std::to_string(check.coincident_vertices) + " coincident vertices, " +
         std::to_string(check.degenerate_triangles) + " degenerate triangles, " +
         std::to_string(check.boundary_edges + check.non_manifold_edges + check.non_manifold_vertices +
                        check.inconsistently_oriented_edges) +
         " topology defects, " + std::to_string(check.self_intersections) + " self-intersections";
}

/// Refuses a float32 format whose rounding would break the mesh.
status require_float32_faithful(const encoder_input& input, const char* what) {
  const delivered_check& check = input.float32_check();
  if (check.passed()) return status::success();
  return {errc::limit_exceeded, std::string(what) + ": float32 coordinates break this mesh (" + describe(check) +
                                    "); use the OFF format"};
}

// ---------------------------------------------------------------------------------------------------------------
// Binary writers (little-endian, as glTF and binary_little_endian PLY require; static_assert below).

static_assert(std::endian::native == std::endian::little, "the binary encoders write the host's byte order");

template <class T>
void append_raw(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

void append_raw(std::vector<unsigned char>& out, const void* data, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  out.insert(out.end(), bytes, bytes + size);
}

void pad_to_4(std::vector<unsigned char>& out) {
  while (out.size() % 4 != 0) out.push_back(0);
}

// ---------------------------------------------------------------------------------------------------------------
// glTF (tinygltf builds the document and the GLB container)

constexpr int gltf_float = TINYGLTF_COMPONENT_TYPE_FLOAT;
constexpr int gltf_uint = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;

/// An accessor of `count` elements; bufferView −1 for Draco-compressed data (the extension supplies it).
int add_accessor(tinygltf::Model& model, int buffer_view, int component_type, int type, std::size_t count) {
  tinygltf::Accessor accessor;
  accessor.bufferView = buffer_view;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

/// Appends `size` bytes to buffer 0 as a new buffer view (4-byte aligned, as accessors require).
int add_buffer_view(tinygltf::Model& model, const void* data, std::size_t size, int target) {
  std::vector<unsigned char>& buffer = model.buffers[0].data;
  pad_to_4(buffer);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = size;
  view.target = target;
  append_raw(buffer, data, size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

/// The skeleton every GLB shares: asset, one buffer, one scene with one node showing mesh 0 with one primitive.
tinygltf::Model gltf_skeleton() {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "tracemesh";
  model.buffers.emplace_back();
  tinygltf::Mesh mesh;
  mesh.name = "molecular surface";
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  return model;
}

void set_bounds(tinygltf::Accessor& accessor, const float lo[3], const float hi[3]) {
  accessor.minValues = {lo[0], lo[1], lo[2]};
  accessor.maxValues = {hi[0], hi[1], hi[2]};
}

result<std::string> write_glb(const tinygltf::Model& model) {
  tinygltf::TinyGLTF writer;
  std::ostringstream out;
  if (!writer.WriteGltfSceneToStream(&model, out, false, true)) {
    return status(errc::internal_error, "glb: the glTF writer failed");
  }
  return std::move(out).str();
}

std::vector<float> as_floats(const std::vector<std::int32_t>& values) {
  return {values.begin(), values.end()};
}

// ---------------------------------------------------------------------------------------------------------------
// PLY

std::string ply_header(const surface_mesh& mesh) {
  std::string header = "ply\nformat binary_little_endian 1.0\n";
  header += "comment Gaussian molecular surface written by tracemesh; coordinates in angstroms\n";
  header += "comment atom_index: 0-based index of the atom contributing most to the field at the vertex\n";
  header += "comment component: 0-based connected component, largest area first (as in the report)\n";
  header += "element vertex ";
  append_integer(header, mesh.vertex_count());
  header += "\nproperty float x\nproperty float y\nproperty float z\n";
  header += "property float nx\nproperty float ny\nproperty float nz\n";
  header += "property uint atom_index\nproperty int component\n";
  header += "element face ";
  append_integer(header, mesh.triangle_count());
  header += "\nproperty list uchar uint vertex_indices\nend_header\n";
  return header;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// Checks and the shared derived data

delivered_check check_delivered_mesh(const surface_mesh& decoded) {
  delivered_check check;
  check.coincident_vertices = count_coincident_vertices(decoded.positions);
  surface_mesh geometry;  // orientation against normals is not a delivery property: leave the normals out
  geometry.positions = decoded.positions;
  geometry.triangles = decoded.triangles;
  const mesh_report report = analyze_mesh(geometry);
  check.degenerate_triangles = report.degenerate_triangles + report.invalid_triangles;
  check.boundary_edges = report.boundary_edges;
  check.non_manifold_edges = report.non_manifold_edges;
  check.non_manifold_vertices = report.non_manifold_vertices;
  check.inconsistently_oriented_edges = report.inconsistently_oriented_edges;
  check.self_intersections = report.self_intersections;
  return check;
}

double position_quantization::step() const noexcept {
  return static_cast<double>(range) / static_cast<double>((std::uint64_t{1} << bits) - 1);
}

const std::vector<std::int32_t>& encoder_input::components() const {
  if (!components_) {
    analysis_options options;
    options.check_self_intersections = false;
    options.label_vertices = true;
    const mesh_report report = analyze_mesh(mesh_, options);
    std::vector<std::int32_t> labels(report.vertex_component.size());
    std::transform(report.vertex_component.begin(), report.vertex_component.end(), labels.begin(),
                   [](std::uint32_t c) { return c == std::numeric_limits<std::uint32_t>::max() ? -1 : static_cast<std::int32_t>(c); });
    components_ = std::move(labels);
  }
  return *components_;
}

const result<draco_encoding>& encoder_input::draco() const {
  if (!draco_) draco_ = encode_checked_draco(*this);
  return *draco_;
}

const delivered_check& encoder_input::float32_check() const {
  if (!float32_check_) {
    // The float32 formats write the mesh's own triangles: topology is the certified mesh's, only the geometry can
    // suffer from rounding (coincident vertices, degenerate triangles).
    const surface_mesh rounded = rounded_to_float32(mesh_);
    delivered_check check;
    check.coincident_vertices = count_coincident_vertices(rounded.positions);
    check.degenerate_triangles = count_degenerate_triangles(rounded);
    float32_check_ = check;
  }
  return *float32_check_;
}

// ---------------------------------------------------------------------------------------------------------------
// Draco

result<position_quantization> choose_position_quantization(const surface_mesh& mesh) {
  if (mesh.positions.empty()) return status(errc::invalid_argument, "draco: the mesh has no vertex");
  vec3 lo = mesh.positions.front();
  vec3 hi = lo;
  double max_magnitude = 0;
  for (const vec3& p : mesh.positions) {
    for (int axis = 0; axis < 3; ++axis) {
      if (!std::isfinite(p[axis])) return status(errc::invalid_argument, "draco: non-finite vertex coordinate");
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
      max_magnitude = std::max(max_magnitude, std::fabs(p[axis]));
    }
  }
  position_quantization grid;
  double extent = 0;
  for (int axis = 0; axis < 3; ++axis) {
    // Round the origin down so that every float32 coordinate lies at or above it.
    grid.origin[axis] = std::nextafter(static_cast<float>(lo[axis]), -std::numeric_limits<float>::infinity());
    extent = std::max(extent, hi[axis] - static_cast<double>(grid.origin[axis]));
  }
  // The margin keeps the top coordinate inside the grid despite float rounding, and the range > 0 for one point.
  grid.range = static_cast<float>(extent * (1 + 1e-6) + 1e-3);

  // Error budget per coordinate: the Euclidean bound / √3, minus float32 rounding of the input coordinate, of the
  // offset from the origin, and of the dequantised value (≈ one ulp at the magnitude plus two at the range).
  const double per_axis_budget = draco_settings::max_position_error / std::sqrt(3.0);
  const double float_error = float_ulp(max_magnitude) + 2 * float_ulp(grid.range);
  const double max_step =
      std::min(draco_settings::max_quantization_step, 2 * (per_axis_budget - float_error));  // rounding: half a step
  if (!(max_step > 0)) {
    return status(errc::limit_exceeded, "draco: coordinates this large (" + std::to_string(max_magnitude) +
                                            " Å) cannot keep 0.01 Å in float32; use the OFF format");
  }
  int bits = draco_settings::min_position_bits;
  while (bits <= draco_settings::max_position_bits &&
         static_cast<double>((std::uint64_t{1} << bits) - 1) * max_step < grid.range) {
    ++bits;
  }
  if (bits > draco_settings::max_position_bits) {
    return status(errc::limit_exceeded, "draco: the mesh extent needs more than 30 quantisation bits");
  }
  grid.bits = bits;
  return grid;
}


result<surface_mesh> decode_draco(std::string_view bytes, std::vector<std::int32_t>* components) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    return status(errc::invalid_argument, std::string("draco: ") + decoded.status().error_msg_string());
  }
  const draco::Mesh& mesh = *decoded.value();
  const draco::PointAttribute* positions = mesh.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (!positions || positions->num_components() != 3) {
    return status(errc::invalid_argument, "draco: no 3-component POSITION attribute");
  }
  surface_mesh out;
  out.positions = vec3_attribute_values(*positions, mesh.num_points());
  if (const draco::PointAttribute* normals = mesh.GetNamedAttribute(draco::GeometryAttribute::NORMAL)) {
    out.normals = vec3_attribute_values(*normals, mesh.num_points());
  }
  for (const std::int32_t atom : int_attribute_values(mesh, draco_settings::atom_index_unique_id)) {
    out.atom_index.push_back(static_cast<std::uint32_t>(atom));
  }
  if (components) *components = int_attribute_values(mesh, draco_settings::component_unique_id);
  out.triangles.reserve(mesh.num_faces());
  for (draco::FaceIndex f(0); f < mesh.num_faces(); ++f) {
    const auto& face = mesh.face(f);
    out.triangles.push_back({face[0].value(), face[1].value(), face[2].value()});
  }
  return out;
}

namespace {

/// The names of the formats that store positions without a quantisation grid, from the format table.
std::string exact_formats() {
  std::string names;
  for (const mesh_format_info& row : mesh_formats()) {
    if (row.positions == position_encoding::draco_grid) continue;
    names += (names.empty() ? "" : ", ") + std::string(row.name);
  }
  return names;
}

}  // namespace

result<draco_encoding> encode_checked_draco(const encoder_input& input) {
  const surface_mesh& mesh = input.mesh();
  if (const status valid = check_encoder_input(mesh, "draco"); !valid) return valid;
  const result<position_quantization> initial = choose_position_quantization(mesh);
  if (!initial) return initial.error();
  const std::unique_ptr<draco::Mesh> draco_mesh = to_draco_mesh(mesh, input.components());

  // The bounding-box grid first; one more bit while the decoded mesh fails its check. A raise halves the step, so
  // vertices that quantisation merged, or corners it made collinear, separate again.
  const int last_bits = std::min(draco_settings::max_position_bits, initial->bits + draco_settings::max_bits_raised);
  delivered_check last;
  for (int bits = initial->bits; bits <= last_bits; ++bits) {
    position_quantization grid = *initial;
    grid.bits = bits;
    result<std::string> bytes = draco_bytes(*draco_mesh, grid);
    if (!bytes) return bytes.error();
    result<surface_mesh> decoded = decode_draco(*bytes);
    if (!decoded) return status(errc::internal_error, "draco: cannot decode its own bytes: " + decoded.error().message());
    // The cheap geometric part first: a grid that merges vertices or flattens triangles needs no further look.
    last = delivered_check{};
    last.coincident_vertices = count_coincident_vertices(decoded->positions);
    last.degenerate_triangles = count_degenerate_triangles(*decoded);
    if (!last.passed()) continue;
    last = check_delivered_mesh(*decoded);
    if (!last.passed()) continue;
    draco_encoding encoding;
    encoding.bytes = std::move(*bytes);
    encoding.grid = grid;
    encoding.bits_raised = bits - initial->bits;
    encoding.decoded = last;
    for (int axis = 0; axis < 3; ++axis) {
      encoding.decoded_min[axis] = std::numeric_limits<float>::infinity();
      encoding.decoded_max[axis] = -std::numeric_limits<float>::infinity();
    }
    for (const vec3& p : decoded->positions) {
      for (int axis = 0; axis < 3; ++axis) {
        encoding.decoded_min[axis] = std::min(encoding.decoded_min[axis], static_cast<float>(p[axis]));
        encoding.decoded_max[axis] = std::max(encoding.decoded_max[axis], static_cast<float>(p[axis]));
      }
    }
    return encoding;
  }
  return status(errc::limit_exceeded, "draco: quantisation breaks this mesh (" + describe(last) +
                                         "); formats without a quantisation grid carry it: " + exact_formats());
}

result<std::string> encode_draco(const encoder_input& input) {
  const result<draco_encoding>& encoding = input.draco();
  if (!encoding) return encoding.error();
  return encoding->bytes;
}

// ---------------------------------------------------------------------------------------------------------------
// OFF

result<std::string> encode_off(const encoder_input& input) {
  const surface_mesh& mesh = input.mesh();
  const int digits = off_significant_digits(mesh);
  std::string out;
  out.reserve(16 + mesh.vertex_count() * 40 + mesh.triangle_count() * 24);
  out += "OFF\n";
  append_integer(out, mesh.vertex_count());
  out += ' ';
  append_integer(out, mesh.triangle_count());
  out += " 0\n";
  for (const vec3& p : mesh.positions) {
    append_general(out, p.x, digits);
    out += ' ';
    append_general(out, p.y, digits);
    out += ' ';
    append_general(out, p.z, digits);
    out += '\n';
  }
  for (const auto& t : mesh.triangles) {
    out += "3 ";
    append_integer(out, t[0]);
    out += ' ';
    append_integer(out, t[1]);
    out += ' ';
    append_integer(out, t[2]);
    out += '\n';
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// glTF

result<std::string> encode_glb(const encoder_input& input) {
  const result<draco_encoding>& encoding = input.draco();
  if (!encoding) return encoding.error();
  const surface_mesh& mesh = input.mesh();
  tinygltf::Model model = gltf_skeleton();
  const int draco_view = add_buffer_view(model, encoding->bytes.data(), encoding->bytes.size(), 0);
  tinygltf::Primitive& primitive = model.meshes[0].primitives[0];
  const std::size_t n = mesh.vertex_count();
  tinygltf::Value::Object draco_attributes;
  const auto add_compressed = [&](const char* semantic, int type, int draco_id) {
    const int accessor = add_accessor(model, -1, gltf_float, type, n);
    primitive.attributes[semantic] = accessor;
    draco_attributes[semantic] = tinygltf::Value(draco_id);
    return accessor;
  };
  const int position = add_compressed("POSITION", TINYGLTF_TYPE_VEC3, 0);
  set_bounds(model.accessors[static_cast<std::size_t>(position)], encoding->decoded_min, encoding->decoded_max);
  if (!mesh.normals.empty()) add_compressed("NORMAL", TINYGLTF_TYPE_VEC3, 1);
  if (!mesh.atom_index.empty()) {
    add_compressed("_ATOM_INDEX", TINYGLTF_TYPE_SCALAR, static_cast<int>(draco_settings::atom_index_unique_id));
  }
  add_compressed("_COMPONENT", TINYGLTF_TYPE_SCALAR, static_cast<int>(draco_settings::component_unique_id));
  primitive.indices = add_accessor(model, -1, gltf_uint, TINYGLTF_TYPE_SCALAR, 3 * mesh.triangle_count());
  tinygltf::Value::Object extension;
  extension["bufferView"] = tinygltf::Value(draco_view);
  extension["attributes"] = tinygltf::Value(std::move(draco_attributes));
  primitive.extensions["KHR_draco_mesh_compression"] = tinygltf::Value(std::move(extension));
  model.extensionsUsed = {"KHR_draco_mesh_compression"};
  model.extensionsRequired = {"KHR_draco_mesh_compression"};
  return write_glb(model);
}

result<std::string> encode_glb_raw(const encoder_input& input) {
  const surface_mesh& mesh = input.mesh();
  if (const status valid = check_encoder_input(mesh, "glb-raw"); !valid) return valid;
  if (const status faithful = require_float32_faithful(input, "glb-raw"); !faithful) return faithful;
  const std::size_t n = mesh.vertex_count();
  tinygltf::Model model = gltf_skeleton();
  tinygltf::Primitive& primitive = model.meshes[0].primitives[0];
  const auto add_attribute_data = [&](const char* semantic, const std::vector<float>& values, int type) {
    const int view = add_buffer_view(model, values.data(), values.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
    const int accessor = add_accessor(model, view, gltf_float, type, n);
    primitive.attributes[semantic] = accessor;
    return accessor;
  };

  std::vector<float> positions;
  positions.reserve(3 * n);
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const vec3& p : mesh.positions) {
    for (int axis = 0; axis < 3; ++axis) {
      const auto value = static_cast<float>(p[axis]);
      positions.push_back(value);
      lo[axis] = std::min(lo[axis], value);
      hi[axis] = std::max(hi[axis], value);
    }
  }
  const int position = add_attribute_data("POSITION", positions, TINYGLTF_TYPE_VEC3);
  set_bounds(model.accessors[static_cast<std::size_t>(position)], lo, hi);
  if (!mesh.normals.empty()) {
    std::vector<float> normals;
    normals.reserve(3 * n);
    for (const vec3& normal : mesh.normals) {
      const std::array<float, 3> f = to_float3(normal);
      normals.insert(normals.end(), f.begin(), f.end());
    }
    add_attribute_data("NORMAL", normals, TINYGLTF_TYPE_VEC3);
  }
  if (!mesh.atom_index.empty()) {
    add_attribute_data("_ATOM_INDEX", std::vector<float>(mesh.atom_index.begin(), mesh.atom_index.end()),
                       TINYGLTF_TYPE_SCALAR);
  }
  add_attribute_data("_COMPONENT", as_floats(input.components()), TINYGLTF_TYPE_SCALAR);
  std::vector<std::uint32_t> indices;
  indices.reserve(3 * mesh.triangle_count());
  for (const auto& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
  const int index_view = add_buffer_view(model, indices.data(), indices.size() * sizeof(std::uint32_t),
                                         TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  primitive.indices = add_accessor(model, index_view, gltf_uint, TINYGLTF_TYPE_SCALAR, indices.size());
  return write_glb(model);
}

// ---------------------------------------------------------------------------------------------------------------
// PLY

result<std::string> encode_ply(const encoder_input& input) {
  const surface_mesh& mesh = input.mesh();
  if (const status valid = check_encoder_input(mesh, "ply"); !valid) return valid;
  if (const status faithful = require_float32_faithful(input, "ply"); !faithful) return faithful;
  const std::vector<std::int32_t>& components = input.components();
  std::string out = ply_header(mesh);
  out.reserve(out.size() + mesh.vertex_count() * 32 + mesh.triangle_count() * 13);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    for (const float value : to_float3(mesh.positions[i])) append_raw(out, value);
    const std::array<float, 3> normal = i < mesh.normals.size() ? to_float3(mesh.normals[i]) : std::array<float, 3>{};
    for (const float value : normal) append_raw(out, value);
    append_raw(out, i < mesh.atom_index.size() ? mesh.atom_index[i] : std::uint32_t{0});
    append_raw(out, components[i]);
  }
  for (const auto& t : mesh.triangles) {
    append_raw(out, std::uint8_t{3});
    for (const std::uint32_t vertex : t) append_raw(out, vertex);
  }
  return out;
}

result<std::string> encode_mesh(const surface_mesh& mesh, mesh_format format) {
  return format_info(format).encode(encoder_input(mesh));
}

std::string encode_msms_vert(const surface_mesh& mesh) {
  std::string out = "# MSMS-format vertices of a Gaussian molecular surface, written by tracemesh\n";
  out += "#vertex #sphere density probe_r\n";
  out += msms_counts_line(mesh, mesh.vertex_count());
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const vec3& p = mesh.positions[i];
    const vec3 normal = i < mesh.normals.size() ? mesh.normals[i] : vec3{};
    for (const double value : {p.x, p.y, p.z, normal.x, normal.y, normal.z}) {
      append_fixed(out, value, msms_decimals);
      out += ' ';
    }
    out += "0 ";
    append_integer(out, i < mesh.atom_index.size() ? mesh.atom_index[i] + 1ULL : 0ULL);
    out += " 2\n";
  }
  return out;
}

std::string encode_msms_face(const surface_mesh& mesh) {
  std::string out = "# MSMS-format triangles of a Gaussian molecular surface, written by tracemesh\n";
  out += "#faces #sphere density probe_r\n";
  out += msms_counts_line(mesh, mesh.triangle_count());
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t vertex : t) {
      append_integer(out, vertex + 1ULL);
      out += ' ';
    }
    out += "2 1\n";
  }
  return out;
}

}  // namespace tracemesh::proto
