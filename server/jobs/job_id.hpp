#pragma once
/// @file job_id.hpp
/// Job identity: the SHA-256 of a canonical serialization of what determines the mesh, so that the same atoms
/// and parameters give the same id however the upload was formatted (spacing, remarks, gzip, CRLF) and whatever
/// its format (PQR, PDB, mmCIF, xyzr): only what the mesher reads — centres and radii — is hashed.
///
/// Serialization (all numbers little-endian):
///   "tracemesh-job-v3\0" engine_version "\0"
///   u64 atom count, then per atom in file order: f64 x, y, z, radius
///   proto::canonical_parameters(params): "density=…;d=…;t0=…;method=…;refine=…" and, for the trace method only,
///   ";trace_degree=…;trace_step=…;trace_cos_bound=…;trace_extreme_tolerance=…" (shortest round-trip numbers, so
///   distinct values never share a spelling)
/// An omitted request parameter and its default spelled out give the same id; the trace parameters do not change
/// the id of a lattice job (they do not change its mesh or report). params.threads is excluded (it never changes
/// the output); so is the output format: one job produces the mesh, which the job store keeps (job_store.hpp), and
/// its encodings, made on request, are cached as "<id>.<format name>" ('-' spelled '_': "<id>.off", "<id>.draco",
/// "<id>.glb_raw", ...; mesh_key). (v1 hashed f64 density, d, t0 and knew no method: v1 ids are simply never asked
/// for again; v2 also hashed the charge, which no output depends on, so a PQR and the PDB of the same atoms were two
/// jobs.)

#include <string>

#include "core/mesher.hpp"
#include "core/molecule.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::server {

/// 64 lower-case hex characters (is_valid_job_id holds). Linear in the atom count; hashes in 64 KiB blocks.
std::string compute_job_id(const molecule& mol, const mesh_params& params);

/// Cache key of a job's encoding in `format`.
std::string mesh_key(const std::string& job_id, proto::mesh_format format);

}  // namespace tracemesh::server
