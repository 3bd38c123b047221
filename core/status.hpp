#pragma once
/// @file status.hpp
/// Errors as values at module edges: `status` (code + message) and `result<T>` (a value or a status).
/// Exceptions are reserved for programmer errors; no function of core/ throws on bad input.

#include <string>
#include <utility>
#include <variant>

namespace tracemesh {

/// Why an operation failed. Callers map these onto exit codes (cli) or HTTP statuses (server).
enum class errc {
  ok = 0,
  invalid_input,      ///< malformed input (bad PQR line, NaN, negative radius...): HTTP 400
  nothing_to_mesh,    ///< well-formed input with no surface (no atoms with radius > 0): HTTP 422
  invalid_argument,   ///< parameter out of its documented range (density, d, t0): HTTP 400
  limit_exceeded,     ///< input over a named limit (atoms, extent, grid cells, triangles): HTTP 413/422
  cancelled,          ///< the progress token asked to stop
  io_error,           ///< a file could not be read or written
  internal_error,     ///< a certificate check failed: a bug, never a silent wrong mesh
  unresolvable_input, ///< well-formed atoms the sampling cannot resolve (parameter_ranges::
                      ///< min_atom_surface_radius_per_edge): HTTP 422
};

/// Stable machine-readable name of an error code ("invalid_input"...), used in JSON error bodies.
const char* errc_name(errc code) noexcept;

class status {
 public:
  status() = default;
  status(errc code, std::string message) : code_(code), message_(std::move(message)) {}

  static status success() { return {}; }
  bool ok() const noexcept { return code_ == errc::ok; }
  explicit operator bool() const noexcept { return ok(); }
  errc code() const noexcept { return code_; }
  const std::string& message() const noexcept { return message_; }

 private:
  errc code_ = errc::ok;
  std::string message_;
};

/// Either a T or a non-ok status.
template <class T>
class result {
 public:
  result(T value) : state_(std::move(value)) {}  // NOLINT: implicit by design
  result(status error) : state_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const noexcept { return state_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & { return std::get<0>(state_); }
  const T& value() const& { return std::get<0>(state_); }
  T&& value() && { return std::get<0>(std::move(state_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  /// The error; a default (ok) status when this holds a value.
  status error() const { return ok() ? status{} : std::get<1>(state_); }

 private:
  std::variant<T, status> state_;
};

}  // namespace tracemesh
