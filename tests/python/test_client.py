"""tracemesh.Client against the real tracemeshd on a loopback port: a mesh equal to the local one, job(id), the
event stream, cancelling with the owner token, and error bodies as ServiceError."""

import numpy as np
import pytest

import tracemesh


def without_timings(report: dict) -> dict:
    return {key: value for key, value in report.items() if key not in ("timings", "encodings")}


@pytest.fixture(scope="module")
def local_fas2(molecules):
    return tracemesh.mesh(tracemesh.read_molecule(molecules / "fas2.pqr"), density=2)


def test_the_services_mesh_is_the_local_one(start_tracemeshd, molecules, local_fas2):
    client = tracemesh.Client(start_tracemeshd().url)
    documents = []
    mesh = client.mesh(molecules / "fas2.pqr", density=2, progress=documents.append)
    # PLY carries float32 positions and normals, the atom index and the component of each vertex.
    np.testing.assert_array_equal(mesh.vertices, local_fas2.vertices.astype(np.float32))
    np.testing.assert_array_equal(mesh.normals, local_fas2.normals.astype(np.float32))
    np.testing.assert_array_equal(mesh.faces, local_fas2.faces)
    np.testing.assert_array_equal(mesh.atom_index, local_fas2.atom_index)
    assert without_timings(mesh.report) == without_timings(local_fas2.report)
    assert documents and documents[-1]["status"] == "done"

    off = client.mesh(molecules / "fas2.pqr", format="off", density="2.0")  # the same job: "2.0" is 2
    np.testing.assert_array_equal(off.faces, local_fas2.faces)
    assert off.encode("off") == local_fas2.encode("off")


def test_submit_job_events_and_download(start_tracemeshd, molecules, local_fas2):
    client = tracemesh.Client(start_tracemeshd().url)
    submitted = client.submit(molecules / "fas2.pqr", density=2, format="off")
    assert set(submitted) >= {"id", "status", "token", "links"} and len(submitted["id"]) == 64
    done = client.wait(submitted["id"])
    assert done["status"] == "done" and done["id"] == submitted["id"]
    job = client.job(submitted["id"])
    assert job["status"] == "done" and without_timings(job["report"]) == without_timings(local_fas2.report)
    events = list(client.events(submitted["id"]))  # a finished job's final event comes at once
    assert events[-1][0] == "done"
    assert client.download(submitted["id"], "off") == local_fas2.encode("off")
    assert client.download(submitted["id"], "ply") == local_fas2.encode("ply")


def test_an_error_body_is_a_service_error(start_tracemeshd, molecules):
    client = tracemesh.Client(start_tracemeshd().url)
    with pytest.raises(tracemesh.ServiceError) as raised:
        client.submit(molecules / "fas2.pqr", density=50)
    with pytest.raises(ValueError) as local:
        tracemesh.mesh(tracemesh.read_molecule(molecules / "fas2.pqr"), density=50)
    assert (raised.value.status, raised.value.code) == (400, "invalid_argument")
    assert str(raised.value) == str(local.value)
    with pytest.raises(tracemesh.ServiceError) as unknown:
        client.job("0" * 64)
    assert (unknown.value.status, unknown.value.code) == (404, "not_found")
    with pytest.raises(tracemesh.ServiceError) as bad_id:
        client.job("not-an-id")
    assert (bad_id.value.status, bad_id.value.code) == (400, "invalid_argument")  # openapi.json InvalidJobId
    with pytest.raises(TypeError, match="unknown parameter 'densty'"):
        client.submit(molecules / "fas2.pqr", densty=2)
    with pytest.raises(tracemesh.ServiceError) as refused:
        tracemesh.Client("http://127.0.0.1:1").job("0" * 64)  # nothing listens on port 1
    assert refused.value.code == "unavailable"


def test_a_queued_job_is_cancelled_with_its_token(start_tracemeshd, molecules):
    # One worker and no small-job lane: fas2 waits in the queue behind the large blocker (the integration tests'
    # way to hold a job queued with the real binary).
    client = tracemesh.Client(start_tracemeshd("--workers", "1", "--small-job-workers", "0").url)
    blocker = client.submit(molecules / "2buk_12asu.pqr")
    queued = client.submit(molecules / "fas2.pqr")
    with pytest.raises(tracemesh.ServiceError) as forbidden:
        client.cancel(queued["id"], blocker["token"])
    assert (forbidden.value.status, forbidden.value.code) == (403, "forbidden")
    cancelled = client.cancel(queued["id"], queued["token"])
    assert cancelled["status"] == "cancelled"
    assert client.job(queued["id"])["status"] == "cancelled"
    with pytest.raises(tracemesh.ServiceError) as ended:
        client.wait(queued["id"])
    assert (ended.value.status, ended.value.code, ended.value.job_id) == (0, "cancelled", queued["id"])
    # The running blocker: its last owner withdrew, so the mesher is stopped and the job ends cancelled.
    assert client.cancel(blocker["id"], blocker["token"])["status"] in ("running", "cancelled")
    with pytest.raises(tracemesh.ServiceError) as stopped:
        client.wait(blocker["id"])
    assert stopped.value.code == "cancelled"


def test_a_bearer_token_is_sent(start_tracemeshd, molecules, tmp_path):
    tokens = tmp_path / "tokens"
    tokens.write_text("python-client-test-token\n")
    url = start_tracemeshd("--auth-token-file", str(tokens)).url
    with pytest.raises(tracemesh.ServiceError) as unauthorized:
        tracemesh.Client(url).submit(molecules / "fas2.pqr")
    assert (unauthorized.value.status, unauthorized.value.code) == (401, "unauthorized")
    mesh = tracemesh.Client(url, token="python-client-test-token").mesh(molecules / "fas2.pqr")
    assert mesh.report["vertices"] == len(mesh.vertices) > 0


INTERRUPTED_CLIENT = """
import sys
import tracemesh

def progress(document):
    print(document["id"], flush=True)  # the job is accepted and queued behind the blocker

try:
    tracemesh.Client(sys.argv[1]).mesh(sys.argv[2], progress=progress)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(0)
sys.exit(1)
"""


def test_ctrl_c_in_client_mesh_withdraws_the_job(start_tracemeshd, molecules, tmp_path):
    import signal
    import subprocess
    import sys

    server = start_tracemeshd("--workers", "1", "--small-job-workers", "0")
    client = tracemesh.Client(server.url)
    blocker = client.submit(molecules / "2buk_12asu.pqr")
    script = tmp_path / "interrupted_client.py"
    script.write_text(INTERRUPTED_CLIENT)
    child = subprocess.Popen([sys.executable, str(script), server.url, str(molecules / "fas2.pqr")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        job_id = child.stdout.readline().strip()
        assert client.job(job_id)["status"] == "queued"
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=300)  # bounds only a failing run
    finally:
        child.kill()
    assert (child.returncode, out) == (0, "interrupted\n"), err
    assert client.job(job_id)["status"] == "cancelled"
    client.cancel(blocker["id"], blocker["token"])
