"""A client of the tracemeshd HTTP service (docs/api.md, proto/openapi.json), with the standard library only.

``Client(url).mesh(path, **params)`` uploads the molecule to POST /jobs (multipart, the file in the field
``structure``), follows GET /jobs/{id}/events (Server-Sent Events) until the job ends, downloads GET
/jobs/{id}/mesh in PLY (default) or OFF and decodes it into the arrays of a :class:`tracemesh.Mesh`.
"""

from __future__ import annotations

import http.client
import json
import os
import urllib.parse
import uuid
from typing import TYPE_CHECKING, Any, Callable, Dict, Iterator, Optional, Tuple, Union

from ._decode import decode_mesh

if TYPE_CHECKING:
    from . import Mesh
from ._errors import ParameterError, ServiceError
from ._fields import field_texts

__all__ = ["Client"]

#: Seconds a request (or a silent event stream, which the server keeps alive every 15 s) may wait for data.
DEFAULT_TIMEOUT = 60.0


class Client:
    """A tracemeshd at ``url`` ("http://host:port", optionally with a path prefix); ``token`` is the bearer token
    of a service started with --auth-token-file. Every error answer raises ServiceError (``status`` the HTTP
    status, ``code`` and ``message`` those of the JSON error body)."""

    def __init__(self, url: str, token: Optional[str] = None, timeout: float = DEFAULT_TIMEOUT) -> None:
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise ParameterError(f"url must be http://host:port or https://host:port, got {url!r}",
                                 "invalid_argument")
        self.url = url
        self._parts = parts
        self._prefix = parts.path.rstrip("/")
        self._token = token
        self._timeout = timeout

    # ---- the routes ---------------------------------------------------------------------------------------------

    def submit(self, path: Union[str, "os.PathLike[str]"], *, format: Optional[str] = None,
               **params: Any) -> Dict[str, Any]:
        """POST /jobs: uploads the molecule file with the mesh parameters and input options (the names of
        tracemesh.mesh and tracemesh.read_molecule) and ``format``, the default encoding of the job's mesh.
        Returns the job document {id, status, token, links}; ``token`` is what cancel() needs."""
        from . import INPUT_OPTIONS, MESH_PARAMETERS

        fields = field_texts(params, MESH_PARAMETERS + INPUT_OPTIONS)
        if format is not None:
            fields["format"] = format
        with open(path, "rb") as file:
            content = file.read()
        body, content_type = _multipart(fields, os.path.basename(os.fspath(path)), content)
        return self._json("POST", "/jobs", body, {"Content-Type": content_type})

    def job(self, job_id: str) -> Dict[str, Any]:
        """GET /jobs/{id}: status, progress, stage, eta_s, queue_position, the report once done, the error once
        failed or cancelled."""
        return self._json("GET", f"/jobs/{_quoted(job_id)}")

    def events(self, job_id: str) -> Iterator[Tuple[str, Dict[str, Any]]]:
        """GET /jobs/{id}/events: (event, job document) pairs, "progress" on every change, then one "done" or
        "error", after which the stream ends."""
        connection, response = self._open("GET", f"/jobs/{_quoted(job_id)}/events", None,
                                          {"Accept": "text/event-stream"})
        try:
            event, data = "message", []
            for raw in response:
                line = raw.decode("utf-8").rstrip("\r\n")
                if not line:
                    if data:
                        yield event, json.loads("\n".join(data))
                    event, data = "message", []
                elif line.startswith(":"):
                    continue  # a keep-alive comment
                else:
                    name, _, value = line.partition(":")
                    value = value[1:] if value.startswith(" ") else value
                    if name == "event":
                        event = value
                    elif name == "data":
                        data.append(value)
        finally:
            connection.close()

    def wait(self, job_id: str, progress: Optional[Callable[[Dict[str, Any]], None]] = None) -> Dict[str, Any]:
        """Follows the job's events until it ends; ``progress`` gets each job document. Returns the final
        document of a done job; raises ServiceError (status 0, the job's error code) for a failed or cancelled
        one."""
        for event, document in self.events(job_id):
            if progress is not None:
                progress(document)
            if event == "done":
                return document
            if event == "error":
                error = document.get("error") or {}
                raise ServiceError(error.get("message", "the job failed"), error.get("code", "internal_error"),
                                   0, job_id)
        raise ServiceError("the event stream ended before the job did", "unavailable", 0, job_id)

    def download(self, job_id: str, format: str = "ply") -> bytes:
        """GET /jobs/{id}/mesh?format=: the mesh's bytes in any format of the service (off, draco, glb, glb-raw,
        ply)."""
        query = urllib.parse.urlencode({"format": format})
        _, body = self._request("GET", f"/jobs/{_quoted(job_id)}/mesh?{query}")
        return body

    def cancel(self, job_id: str, token: str) -> Dict[str, Any]:
        """DELETE /jobs/{id} with X-Job-Token: withdraws this submission; the job is cancelled when no other
        owner holds it. Returns the job document (status "cancelled", or "queued"/"running" while others hold
        it); 409 (ServiceError) once the job has finished."""
        return self._json("DELETE", f"/jobs/{_quoted(job_id)}", None, {"X-Job-Token": token})

    def mesh(self, path: Union[str, "os.PathLike[str]"], *, format: str = "ply",
             progress: Optional[Callable[[Dict[str, Any]], None]] = None, **params: Any) -> "Mesh":
        """Meshes a molecule file on the service: submit(), wait(), then the mesh in ``format`` ("ply": float32
        positions and normals, atom indices and components; "off": positions at 1e-6 Å, no normals) decoded,
        with the job's report. Ctrl-C cancels the job (withdraws this submission) and raises KeyboardInterrupt."""
        if format not in ("ply", "off"):
            raise ParameterError(f"Client.mesh decodes ply or off, not {format!r} (download() gives any "
                                 "format's bytes)", "invalid_argument")
        submitted = self.submit(path, format=format, **params)
        job_id = submitted["id"]
        try:
            done = self.wait(job_id, progress)
        except KeyboardInterrupt:
            try:
                self.cancel(job_id, submitted["token"])
            except ServiceError:
                pass  # finished meanwhile: nothing left to cancel
            raise
        return decode_mesh(self.download(job_id, format), format, done.get("report") or {})

    # ---- HTTP -------------------------------------------------------------------------------------------------

    def _open(self, method: str, target: str, body: Optional[bytes],
              headers: Dict[str, str]) -> Tuple[http.client.HTTPConnection, http.client.HTTPResponse]:
        """The response to one request on a new connection; ServiceError for a non-2xx answer."""
        kind = http.client.HTTPSConnection if self._parts.scheme == "https" else http.client.HTTPConnection
        connection = kind(self._parts.hostname, self._parts.port, timeout=self._timeout)
        headers = dict(headers)
        if self._token is not None:
            headers["Authorization"] = f"Bearer {self._token}"
        try:
            connection.request(method, self._prefix + target, body, headers)
            response = connection.getresponse()
        except OSError as error:
            connection.close()
            raise ServiceError(f"{method} {self.url}{target}: {error}", "unavailable") from error
        if not 200 <= response.status < 300:
            payload = response.read()
            connection.close()
            raise _service_error(response.status, response.reason, payload)
        return connection, response

    def _request(self, method: str, target: str, body: Optional[bytes] = None,
                 headers: Optional[Dict[str, str]] = None) -> Tuple[int, bytes]:
        connection, response = self._open(method, target, body, headers or {})
        try:
            return response.status, response.read()
        finally:
            connection.close()

    def _json(self, method: str, target: str, body: Optional[bytes] = None,
              headers: Optional[Dict[str, str]] = None) -> Dict[str, Any]:
        _, payload = self._request(method, target, body, headers)
        return json.loads(payload)


def _quoted(job_id: str) -> str:
    return urllib.parse.quote(job_id, safe="")


def _service_error(status: int, reason: str, payload: bytes) -> ServiceError:
    """The error of a non-2xx answer: its JSON body's code and message (every tracemeshd error has one)."""
    try:
        error = json.loads(payload)["error"]
        return ServiceError(str(error["message"]), str(error["code"]), status)
    except (ValueError, KeyError, TypeError):
        return ServiceError(f"HTTP {status} {reason}", "http_error", status)


def _multipart(fields: Dict[str, str], file_name: str, content: bytes) -> Tuple[bytes, str]:
    """A multipart/form-data body: the text fields, then the molecule in the field 'structure'."""
    boundary = "tracemesh-" + uuid.uuid4().hex
    parts = []
    for name, value in fields.items():
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n{value}\r\n'.encode())
    safe_name = file_name.replace('"', "_").replace("\r", "_").replace("\n", "_")
    parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="structure"; filename="{safe_name}"\r\n'
                 f"Content-Type: application/octet-stream\r\n\r\n".encode() + content + b"\r\n")
    parts.append(f"--{boundary}--\r\n".encode())
    return b"".join(parts), f"multipart/form-data; boundary={boundary}"
