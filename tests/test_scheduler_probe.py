"""``--scheduler`` addresses that reach something other than a dask scheduler
(viscore._jobs.check_scheduler): one line, never a hang or an internal error."""

from __future__ import annotations

import socket
import threading

import dask
import pytest

from viscore import InputError
from viscore._jobs import check_scheduler, connect_scheduler


class _Server:
    """A TCP server on a free local port that greets each connection with ``greeting``
    (None: says nothing and keeps the connection open; b"": closes it at once)."""

    def __init__(self, greeting: bytes | None):
        self.greeting = greeting
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.held: list[socket.socket] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            if self.greeting is None:
                self.held.append(conn)
                continue
            conn.sendall(self.greeting)
            conn.close()

    def close(self):
        self.sock.close()
        for c in self.held:
            c.close()


@pytest.fixture
def server():
    made = []

    def make(greeting):
        made.append(_Server(greeting))
        return made[-1]

    yield make
    for s in made:
        s.close()


def test_a_server_that_greets_with_another_protocol_is_refused(server):
    # an SSH port: distributed's client read "SSH-2.0-" as a frame of 3.3e18 bytes and
    # died of a MemoryError (exit 3)
    ssh = server(b"SSH-2.0-OpenSSH_9.6p1 Ubuntu-3ubuntu13.5\r\n")
    with pytest.raises(InputError, match=r"answered b'SSH-2.0-', not a dask scheduler's "
                                         r"greeting"):
        connect_scheduler(f"tcp://127.0.0.1:{ssh.port}")


def test_a_server_that_accepts_and_stays_silent_is_refused_after_the_connect_timeout(server):
    # the client waited for the handshake for ever: no timeout covers that read
    silent = server(None)
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}), \
            pytest.raises(InputError, match="accepted the connection but sent nothing in 1 s"):
        check_scheduler(f"127.0.0.1:{silent.port}")


def test_a_server_that_closes_at_once_is_refused(server):
    closing = server(b"")
    with pytest.raises(InputError, match="closed the connection without a dask scheduler's"):
        check_scheduler(f"tcp://127.0.0.1:{closing.port}")


@pytest.mark.parametrize("port", ["0", "65536", "99999", "-1"])
def test_a_port_outside_the_tcp_range_is_named(port):
    with pytest.raises(InputError, match=f"port {port} is not a TCP port"):
        check_scheduler(f"tcp://127.0.0.1:{port}")


def test_a_websocket_address_whose_port_refuses_is_one_line_at_once():
    with socket.create_server(("127.0.0.1", 0)) as s:
        port = s.getsockname()[1]  # free once closed: nothing listens there
    with pytest.raises(InputError, match="connection refused"):
        check_scheduler(f"ws://127.0.0.1:{port}")


def test_an_unknown_inproc_address_says_so():
    with pytest.raises(InputError, match="no scheduler of this process has that inproc://"):
        connect_scheduler("inproc://nowhere")


def test_a_real_scheduler_passes_the_probe():
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                      dashboard_address=None) as cluster:
        check_scheduler(cluster.scheduler_address)
        with connect_scheduler(cluster.scheduler_address) as client:
            assert client.submit(int, "42").result() == 42
