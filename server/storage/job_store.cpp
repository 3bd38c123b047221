#include "server/storage/job_store.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include <nlohmann/json.hpp>

#include "proto/api_types.hpp"
#include "server/storage/detail/durable_file.hpp"
#include "server/storage/content_hash.hpp"
#include "server/jobs/job_id.hpp"

namespace tracemesh::server {

namespace fs = std::filesystem;

namespace {

static_assert(std::endian::native == std::endian::little, "stored files are little-endian byte images");

constexpr std::string_view record_magic = "tmjobrec";
constexpr std::string_view input_magic = "tmjobinp";
constexpr std::string_view result_magic = "tmjobres";
constexpr std::string_view record_extension = ".record";
constexpr std::string_view input_extension = ".input";
constexpr std::string_view result_extension = ".result";

template <typename T>
void append_array(std::string& out, const std::vector<T>& values) {
  const std::uint64_t count = values.size();
  out.append(reinterpret_cast<const char*>(&count), sizeof count);
  out.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

/// Reads arrays written by append_array, checking every length against what is left.
class array_reader {
 public:
  explicit array_reader(std::string_view bytes) : bytes_(bytes) {}
  template <typename T>
  bool read(std::vector<T>& values) {
    std::uint64_t count = 0;
    if (bytes_.size() < sizeof count) return false;
    std::memcpy(&count, bytes_.data(), sizeof count);
    bytes_.remove_prefix(sizeof count);
    if (count > bytes_.size() / sizeof(T)) return false;
    values.resize(count);
    if (count != 0) std::memcpy(values.data(), bytes_.data(), count * sizeof(T));  // data() may be null when empty
    bytes_.remove_prefix(count * sizeof(T));
    return true;
  }
  bool at_end() const { return bytes_.empty(); }

 private:
  std::string_view bytes_;
};

nlohmann::json record_to_json(const stored_job& record) {
  return {{"id", record.id},
          {"state", std::string(proto::job_state_name(record.state))},
          {"parameters", record.parameters},
          {"format", std::string(proto::format_name(record.format))},
          {"owners", record.owners},
          {"error_code", record.error_code},
          {"error_message", record.error_message},
          {"report", record.report ? nlohmann::json(*record.report) : nlohmann::json(nullptr)},
          {"accepted_ms", record.accepted_ms},
          {"finished_ms", record.finished_ms}};
}

std::optional<stored_job> record_from_json(const std::string& text) {
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return std::nullopt;
  try {
    stored_job record;
    record.id = doc.at("id").get<std::string>();
    result<job_state> state = proto::parse_job_state(doc.at("state").get<std::string>());
    result<proto::mesh_format> format = proto::parse_mesh_format(doc.at("format").get<std::string>());
    if (!state.ok() || !format.ok() || !is_valid_job_id(record.id)) return std::nullopt;
    record.state = *state;
    record.format = *format;
    record.parameters = doc.at("parameters").get<std::string>();
    record.owners = doc.at("owners").get<std::vector<std::string>>();
    record.error_code = doc.at("error_code").get<std::string>();
    record.error_message = doc.at("error_message").get<std::string>();
    if (doc.at("report").is_string()) record.report = std::make_shared<const std::string>(doc.at("report"));
    record.accepted_ms = doc.at("accepted_ms").get<std::int64_t>();
    record.finished_ms = doc.at("finished_ms").get<std::int64_t>();
    return record;
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
}

std::size_t mesh_bytes(const surface_mesh& mesh) {
  return mesh.positions.size() * sizeof(vec3) + mesh.normals.size() * sizeof(vec3) +
         mesh.atom_index.size() * sizeof(std::uint32_t) + mesh.triangles.size() * sizeof(mesh.triangles[0]);
}

}  // namespace

result<mesh_params> parse_canonical_parameters(const std::string& text) {
  std::map<std::string, std::string, std::less<>> fields;
  std::string_view rest = text;
  while (!rest.empty()) {
    const auto semicolon = rest.find(';');
    const std::string_view pair = rest.substr(0, semicolon);
    rest = semicolon == std::string_view::npos ? std::string_view{} : rest.substr(semicolon + 1);
    const auto equals = pair.find('=');
    if (equals == std::string_view::npos) return status(errc::invalid_input, "malformed stored parameters");
    fields.emplace(std::string(pair.substr(0, equals)), std::string(pair.substr(equals + 1)));
  }
  return proto::parse_mesh_params([&](std::string_view name) -> std::optional<std::string> {
    const auto it = fields.find(name);
    if (it == fields.end()) return std::nullopt;
    return it->second;
  });
}

std::int64_t unix_millis() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string serialize_mesh(const surface_mesh& mesh) {
  std::string out;
  out.reserve(mesh_bytes(mesh) + 32);
  append_array(out, mesh.positions);
  append_array(out, mesh.normals);
  append_array(out, mesh.atom_index);
  append_array(out, mesh.triangles);
  return out;
}

std::optional<surface_mesh> deserialize_mesh(std::string_view bytes) {
  surface_mesh mesh;
  array_reader in(bytes);
  if (!in.read(mesh.positions) || !in.read(mesh.normals) || !in.read(mesh.atom_index) || !in.read(mesh.triangles) ||
      !in.at_end()) {
    return std::nullopt;
  }
  for (const auto& triangle : mesh.triangles) {
    for (const std::uint32_t corner : triangle) {
      if (corner >= mesh.positions.size()) return std::nullopt;
    }
  }
  return mesh;
}

std::string serialize_molecule(const molecule& mol) {
  std::string out;
  append_array(out, mol.atoms);
  const std::vector<std::uint64_t> zero_radius{mol.zero_radius_atoms};
  append_array(out, zero_radius);
  return out;
}

std::optional<molecule> deserialize_molecule(std::string_view bytes) {
  molecule mol;
  std::vector<std::uint64_t> zero_radius;
  array_reader in(bytes);
  if (!in.read(mol.atoms) || !in.read(zero_radius) || zero_radius.size() != 1 || !in.at_end()) return std::nullopt;
  mol.zero_radius_atoms = zero_radius[0];
  return mol;
}

job_store::job_store(job_store_options options) : options_(std::move(options)) {}

fs::path job_store::file_path(const std::string& id, std::string_view extension) const {
  return options_.dir / id.substr(0, 2) / (id + std::string(extension));
}

status job_store::open() {
  if (!durable()) return status::success();
  const status usable = detail::ensure_writable_directory(options_.dir, "job directory");
  if (!usable.ok()) return usable;

  std::vector<stored_job> found;
  std::error_code error;
  for (fs::directory_iterator shard(options_.dir, error), end; !error && shard != end; shard.increment(error)) {
    std::error_code inner;
    if (!shard->is_directory(inner)) continue;
    for (fs::directory_iterator file(shard->path(), inner); !inner && file != end; file.increment(inner)) {
      const std::string name = file->path().filename().string();
      if (name.rfind(detail::durable_temp_prefix, 0) == 0) {
        fs::remove(file->path(), inner);  // a killed writer's temporary file: the rename never happened
        continue;
      }
      if (!name.ends_with(record_extension)) continue;
      const std::optional<std::string> sealed = detail::read_whole_file(file->path());
      const std::optional<std::string> text = sealed ? detail::unseal(record_magic, *sealed) : std::nullopt;
      const std::optional<stored_job> record = text ? record_from_json(*text) : std::nullopt;
      if (!record || record->id + std::string(record_extension) != name) {
        // A damaged record cannot be trusted to name its job; its input (if any) is still found below by id.
        lost_.push_back(name.substr(0, name.size() - record_extension.size()));
        fs::remove(file->path(), inner);
        continue;
      }
      found.push_back(*record);
    }
  }
  if (error) return status(errc::io_error, "job directory " + options_.dir.string() + ": " + error.message());

  const std::int64_t now = unix_millis();
  std::lock_guard lock(mutex_);
  for (stored_job& record : found) {
    if (expired(record, now)) {
      records_.emplace(record.id, record);
      forget_locked(record.id);
      continue;
    }
    const bool result_readable =
        record.state != job_state::done || fs::exists(file_path(record.id, result_extension), error);
    if (record.state != job_state::queued && result_readable) {
      records_.emplace(record.id, std::move(record));
      continue;
    }
    // Unfinished (or done without its result): queue it again from its input, which must be whole and hash to
    // the job's own id.
    const std::optional<std::string> sealed = detail::read_whole_file(file_path(record.id, input_extension));
    const std::optional<std::string> bytes = sealed ? detail::unseal(input_magic, *sealed) : std::nullopt;
    std::optional<molecule> mol = bytes ? deserialize_molecule(*bytes) : std::nullopt;
    result<mesh_params> params = parse_canonical_parameters(record.parameters);
    if (!mol || !params.ok() || compute_job_id(*mol, *params) != record.id) {
      record.state = job_state::failed;
      record.error_code = lost_job_error;
      record.error_message = "the server lost this job's input in a crash; submit it again";
      record.finished_ms = now;
      lost_.push_back(record.id);
      (void)write_record(record);
      records_.emplace(record.id, std::move(record));
      continue;
    }
    auto input = std::make_shared<job_input>();
    input->mol = std::move(*mol);
    input->params = *params;
    input->format = record.format;
    record.state = job_state::queued;
    unfinished_.push_back({record, std::move(input)});
    records_.emplace(record.id, std::move(record));
  }
  return status::success();
}

std::vector<unfinished_job> job_store::take_unfinished() {
  std::lock_guard lock(mutex_);
  std::sort(unfinished_.begin(), unfinished_.end(),
            [](const unfinished_job& a, const unfinished_job& b) { return a.record.accepted_ms < b.record.accepted_ms; });
  return std::exchange(unfinished_, {});
}

std::vector<std::string> job_store::take_lost() {
  std::lock_guard lock(mutex_);
  return std::exchange(lost_, {});
}

status job_store::write_record(const stored_job& record) {
  if (!durable()) return status::success();
  return detail::write_file_durably(file_path(record.id, record_extension),
                                    detail::seal(record_magic, record_to_json(record).dump()));
}

status job_store::accept(const stored_job& record, const job_input& input) {
  std::lock_guard writing(write_mutex_);
  if (const std::optional<stored_job> existing = find(record.id); existing && existing->state == job_state::done) {
    return status::success();  // finished meanwhile: its result is already kept
  }
  if (durable()) {
    std::error_code error;
    fs::create_directories(file_path(record.id, input_extension).parent_path(), error);
    if (error) return status(errc::io_error, "job directory: " + error.message());
    const status input_written = detail::write_file_durably(
        file_path(record.id, input_extension), detail::seal(input_magic, serialize_molecule(input.mol)));
    if (!input_written.ok()) return input_written;
    const status record_written = write_record(record);
    if (!record_written.ok()) return record_written;
  }
  std::lock_guard lock(mutex_);
  records_[record.id] = record;
  return status::success();
}

void job_store::forget(const std::string& id) {
  std::lock_guard writing(write_mutex_);
  std::lock_guard lock(mutex_);
  forget_locked(id);
}

status job_store::add_owner(const std::string& id, const std::string& owner_hash) {
  std::lock_guard writing(write_mutex_);
  std::unique_lock lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return status(errc::invalid_argument, "no such job");
  stored_job updated = it->second;
  updated.owners.push_back(owner_hash);
  lock.unlock();
  const status written = write_record(updated);
  if (!written.ok()) return written;
  lock.lock();
  if (const auto again = records_.find(id); again != records_.end()) again->second.owners.push_back(owner_hash);
  return status::success();
}

bool job_store::remove_owner(const std::string& id, const std::string& owner_hash) {
  std::lock_guard writing(write_mutex_);
  std::unique_lock lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return false;
  auto& owners = it->second.owners;
  const auto owner = std::find(owners.begin(), owners.end(), owner_hash);
  if (owner == owners.end()) return false;
  owners.erase(owner);
  const stored_job updated = it->second;
  lock.unlock();
  (void)write_record(updated);  // best effort: a stale owner after a crash can only withdraw again
  return true;
}

status job_store::complete(const std::string& id, const stored_job& record_if_new, const surface_mesh& mesh,
                           std::shared_ptr<const std::string> report) {
  std::lock_guard writing(write_mutex_);
  stored_job record;
  {
    std::lock_guard lock(mutex_);
    const auto it = records_.find(id);
    record = it != records_.end() ? it->second : record_if_new;
  }
  record.id = id;
  record.state = job_state::done;
  record.report = report;
  record.error_code.clear();
  record.error_message.clear();
  record.finished_ms = unix_millis();
  if (durable()) {
    std::error_code error;
    fs::create_directories(file_path(id, result_extension).parent_path(), error);
    const status result_written =
        detail::write_file_durably(file_path(id, result_extension), detail::seal(result_magic, serialize_mesh(mesh)));
    if (!result_written.ok()) return result_written;
    const status record_written = write_record(record);
    if (!record_written.ok()) return record_written;
    (void)detail::remove_file_durably(file_path(id, input_extension));
  }
  std::lock_guard lock(mutex_);
  if (!durable()) {
    auto shared = std::make_shared<const surface_mesh>(mesh);
    memory_used_ += mesh_bytes(mesh) + report->size();
    meshes_[id] = held_mesh{std::move(shared), ++completions_};
  }
  records_[id] = std::move(record);
  enforce_memory_bound_locked();
  return status::success();
}

status job_store::amend_report(const std::string& id,
                               const std::function<std::string(const std::string&)>& amend) {
  std::lock_guard writing(write_mutex_);
  stored_job record;
  {
    std::lock_guard lock(mutex_);
    const auto it = records_.find(id);
    if (it == records_.end() || it->second.state != job_state::done || !it->second.report) {
      return status(errc::invalid_argument, "no done job " + id);
    }
    record = it->second;
  }
  const std::size_t old_size = record.report->size();
  record.report = std::make_shared<const std::string>(amend(*record.report));
  if (const status written = write_record(record); !written.ok()) return written;
  std::lock_guard lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return status::success();  // forgotten meanwhile (retention, memory bound)
  if (!durable()) memory_used_ = memory_used_ - old_size + record.report->size();
  it->second.report = record.report;
  enforce_memory_bound_locked();
  return status::success();
}

status job_store::finish(const std::string& id, job_state state, const std::string& error_code,
                         const std::string& error_message) {
  std::lock_guard writing(write_mutex_);
  stored_job record;
  {
    std::lock_guard lock(mutex_);
    const auto it = records_.find(id);
    if (it == records_.end()) return status::success();  // never accepted (a synchronous job): nothing to keep
    if (it->second.state == job_state::done) return status::success();  // its result is kept whatever came later
    it->second.state = state;
    it->second.error_code = error_code;
    it->second.error_message = error_message;
    it->second.finished_ms = unix_millis();
    record = it->second;
  }
  const status written = write_record(record);
  if (durable()) (void)detail::remove_file_durably(file_path(id, input_extension));
  return written;
}

status job_store::record_encoding(const std::string& id, std::string_view format_name, const nlohmann::json& entry) {
  return amend_report(id, [&](const std::string& report) { return with_encoding(report, format_name, entry); });
}

std::string with_encoding(const std::string& report, std::string_view name, const nlohmann::json& entry) {
  nlohmann::json doc = nlohmann::json::parse(report, nullptr, false);
  if (!doc.is_object()) return report;  // never written by this service; leave it as it is
  nlohmann::json& encodings = doc["encodings"];
  if (!encodings.is_object()) encodings = nlohmann::json::object();
  encodings[std::string(name)] = entry;
  return doc.dump();
}

std::optional<stored_job> job_store::find(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return std::nullopt;
  if (expired(it->second, unix_millis())) {
    forget_locked(id);
    return std::nullopt;
  }
  return it->second;
}

std::shared_ptr<const surface_mesh> job_store::mesh(const std::string& id) {
  const std::optional<stored_job> record = find(id);
  if (!record || record->state != job_state::done) return nullptr;
  if (!durable()) {
    std::lock_guard lock(mutex_);
    const auto it = meshes_.find(id);
    return it == meshes_.end() ? nullptr : it->second.mesh;
  }
  const std::optional<std::string> sealed = detail::read_whole_file(file_path(id, result_extension));
  const std::optional<std::string> bytes = sealed ? detail::unseal(result_magic, *sealed) : std::nullopt;
  std::optional<surface_mesh> mesh = bytes ? deserialize_mesh(*bytes) : std::nullopt;
  if (!mesh) return nullptr;
  return std::make_shared<const surface_mesh>(std::move(*mesh));
}

void job_store::purge_expired() {
  const std::int64_t now = unix_millis();
  std::lock_guard lock(mutex_);
  std::vector<std::string> expired_ids;
  for (const auto& [id, record] : records_) {
    if (expired(record, now)) expired_ids.push_back(id);
  }
  for (const std::string& id : expired_ids) forget_locked(id);
}

std::size_t job_store::records() const {
  std::lock_guard lock(mutex_);
  return records_.size();
}

bool job_store::expired(const stored_job& record, std::int64_t now_ms) const {
  return record.finished_ms != 0 && now_ms - record.finished_ms > options_.retention.count();
}

void job_store::forget_locked(const std::string& id) {
  records_.erase(id);
  if (const auto it = meshes_.find(id); it != meshes_.end()) {
    memory_used_ -= std::min(memory_used_, mesh_bytes(*it->second.mesh));
    meshes_.erase(it);
  }
  if (!durable()) return;
  std::error_code ignored;
  for (const std::string_view extension : {result_extension, input_extension, record_extension}) {
    fs::remove(file_path(id, extension), ignored);
  }
}

void job_store::enforce_memory_bound_locked() {
  if (durable()) return;
  while (memory_used_ > options_.memory_bytes && !meshes_.empty()) {
    // The oldest finished job goes first.
    auto oldest = meshes_.begin();
    for (auto it = meshes_.begin(); it != meshes_.end(); ++it) {
      if (it->second.completion < oldest->second.completion) oldest = it;
    }
    const std::string id = oldest->first;
    if (const auto& report = records_[id].report) memory_used_ -= std::min(memory_used_, report->size());
    forget_locked(id);
  }
}

}  // namespace tracemesh::server
