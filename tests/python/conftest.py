"""What the Python package's tests share: the paths ctest gives (tests/python/tests.cmake) and tracemeshd as a
child process on a free loopback port, as tests/support/tracemeshd_process.hpp starts it."""

import json
import os
import subprocess
import threading
from pathlib import Path
from typing import Iterator, List

import pytest


def _path_from_environment(name: str) -> Path:
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run these tests through ctest (tests/python/tests.cmake)")
    return Path(value)


@pytest.fixture(scope="session")
def molecules() -> Path:
    """The suite's molecules (tests/data/molecules/, copied into the build tree, the .gz files unpacked)."""
    return _path_from_environment("TRACEMESH_TEST_MOLECULES")


@pytest.fixture(scope="session")
def cli() -> Path:
    """The built tracemesh command."""
    return _path_from_environment("TRACEMESH_CLI")


class Tracemeshd:
    """tracemeshd on 127.0.0.1 at the port its "started" log line names; killed by stop()."""

    def __init__(self, binary: Path, args: List[str]) -> None:
        self.process = subprocess.Popen([str(binary), "--listen", "127.0.0.1:0", "--no-disk-store", *args],
                                        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE, text=True)
        self.log: List[str] = []
        self.port = self._read_port()
        # The log keeps being read so that the server never blocks on a full pipe.
        self._drain = threading.Thread(target=self._read_rest, daemon=True)
        self._drain.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def _read_port(self) -> int:
        for line in self.process.stderr:
            self.log.append(line)
            if '"event":"started"' in line:
                return int(json.loads(line)["port"])
        self.process.wait()
        pytest.fail(f"tracemeshd exited ({self.process.returncode}) before it started: {''.join(self.log)}")

    def _read_rest(self) -> None:
        for line in self.process.stderr:
            self.log.append(line)

    def stop(self) -> None:
        self.process.kill()
        self.process.wait()


@pytest.fixture
def start_tracemeshd() -> Iterator:
    """start_tracemeshd(*args) -> Tracemeshd; every server started is killed at the end of the test."""
    binary = _path_from_environment("TRACEMESHD")
    started: List[Tracemeshd] = []

    def start(*args: str) -> Tracemeshd:
        started.append(Tracemeshd(binary, list(args)))
        return started[-1]

    yield start
    for server in started:
        server.stop()
