"""A test VTN (openleadr's OpenADRServer) on 127.0.0.1, in a thread, that stops by itself.

It registers one VEN, queues the events it is given for it, records the opt responses and
every report value it receives, and requests every report the VEN offers at 1 s.
"""

from __future__ import annotations

import asyncio
import subprocess
import threading
import time
from dataclasses import dataclass, field
from datetime import timedelta
from pathlib import Path
from typing import Any

from openleadr import OpenADRServer, utils

VEN_ID = "ven-1"
REGISTRATION_ID = "reg-1"
VTN_ID = "TEST-VTN"
POLL = timedelta(seconds=1)
SAMPLING = timedelta(seconds=1)


@dataclass(frozen=True)
class TlsFiles:
    """A throwaway CA and the VTN's and the VEN's certificates (openssl), PEM."""

    ca: Path
    vtn_cert: Path
    vtn_key: Path
    ven_cert: Path
    ven_key: Path

    @staticmethod
    def make(folder: Path) -> TlsFiles:
        def run(*args: str) -> None:
            subprocess.run(["openssl", *args], check=True, capture_output=True, timeout=60)

        ca, ca_key = folder / "ca.pem", folder / "ca.key"
        run(
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            "2",
            "-subj",
            "/CN=test CA",
            "-keyout",
            str(ca_key),
            "-out",
            str(ca),
        )
        files = {}
        for name, usage in (("vtn", "serverAuth,clientAuth"), ("ven", "clientAuth")):
            key, csr, cert = (folder / f"{name}.{ext}" for ext in ("key", "csr", "pem"))
            ext = folder / f"{name}.ext"
            ext.write_text(f"subjectAltName=IP:127.0.0.1\nextendedKeyUsage={usage}\n")
            run(
                "req",
                "-newkey",
                "rsa:2048",
                "-nodes",
                "-subj",
                f"/CN={name}",
                "-keyout",
                str(key),
                "-out",
                str(csr),
            )
            run(
                "x509",
                "-req",
                "-in",
                str(csr),
                "-CA",
                str(ca),
                "-CAkey",
                str(ca_key),
                "-CAcreateserial",
                "-days",
                "2",
                "-extfile",
                str(ext),
                "-out",
                str(cert),
            )
            files[name] = (cert, key)
        return TlsFiles(ca, *files["vtn"], *files["ven"])


@dataclass
class LoopbackVtn:
    """The VTN; ``events`` are ``add_event`` keyword arguments (without ven_id/callback)."""

    port: int
    events: list[dict[str, Any]]
    tls: TlsFiles | None = None
    run_for_s: float = 120.0
    opts: dict[str, str] = field(default_factory=dict)
    values: dict[str, list[tuple[Any, float]]] = field(default_factory=dict)
    descriptions: dict[str, dict[str, Any]] = field(default_factory=dict)
    registrations: int = 0
    event_ids: list[str] = field(default_factory=list)
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None
    _ready: threading.Event = field(default_factory=threading.Event)
    _server: Any = None
    _loop: asyncio.AbstractEventLoop | None = None

    @property
    def url(self) -> str:
        scheme = "https" if self.tls else "http"
        return f"{scheme}://127.0.0.1:{self.port}/OpenADR2/Simple/2.0b"

    @property
    def fingerprint(self) -> str | None:
        if self.tls is None:
            return None
        return str(utils.certificate_fingerprint(self.tls.vtn_cert.read_bytes()))

    def ven_lookup(self, ven_id: str) -> dict[str, Any]:
        if ven_id != VEN_ID or not self.registrations:
            return {}
        fingerprint = (
            None
            if self.tls is None
            else utils.certificate_fingerprint(self.tls.ven_cert.read_bytes())
        )
        return {
            "ven_id": VEN_ID,
            "ven_name": "site-1",
            "fingerprint": fingerprint,
            "registration_id": REGISTRATION_ID,
        }

    def on_create_party_registration(self, info: dict[str, Any]) -> tuple[str, str] | bool:
        if info.get("ven_name") != "site-1":
            return False
        if self.tls is not None:
            expected = utils.certificate_fingerprint(self.tls.ven_cert.read_bytes())
            if info.get("fingerprint") != expected:
                return False
        self.registrations += 1
        return VEN_ID, REGISTRATION_ID

    def on_register_report(self, report: dict[str, Any]) -> list[tuple[str, Any, timedelta]]:
        requests = []
        for description in report["report_descriptions"]:
            r_id = description["r_id"]
            self.descriptions[r_id] = {
                "report_specifier_id": report["report_specifier_id"],
                "reading_type": description.get("reading_type"),
                "report_type": description.get("report_type"),
                "resource_id": (description.get("report_data_source") or {}).get("resource_id"),
            }

            def store(values: list[tuple[Any, float]], r_id: str = r_id) -> None:
                self.values.setdefault(r_id, []).extend(values)

            requests.append((r_id, store, SAMPLING))
        return requests

    def on_opt(self, ven_id: str, event_id: str, opt_type: str) -> None:
        self.opts[event_id] = opt_type

    async def _serve(self) -> None:
        tls = self.tls
        server = OpenADRServer(
            vtn_id=VTN_ID,
            http_host="127.0.0.1",
            http_port=self.port,
            requested_poll_freq=POLL,
            ven_lookup=self.ven_lookup,
            show_fingerprint=False,
            **(
                {}
                if tls is None
                else {
                    "http_cert": str(tls.vtn_cert),
                    "http_key": str(tls.vtn_key),
                    "http_ca_file": str(tls.ca),
                    "cert": str(tls.vtn_cert),
                    "key": str(tls.vtn_key),
                }
            ),
        )
        server.add_handler("on_create_party_registration", self.on_create_party_registration)
        server.add_handler("on_register_report", self.on_register_report)
        for event in self.events:
            self.event_ids.append(server.add_event(ven_id=VEN_ID, callback=self.on_opt, **event))
        await server.run()
        self._server, self._loop = server, asyncio.get_running_loop()
        self._ready.set()
        deadline = time.monotonic() + self.run_for_s
        while not self._stop.is_set() and time.monotonic() < deadline:
            await asyncio.sleep(0.1)
        await server.stop()

    def start(self) -> None:
        self._thread = threading.Thread(target=lambda: asyncio.run(self._serve()), daemon=True)
        self._thread.start()
        assert self._ready.wait(30), "the VTN did not start"

    def cancel(self, event_id: str) -> None:
        """Cancel an event (a new version, status cancelled, sent at the VEN's next poll)."""
        assert self._loop is not None and self._server is not None, "the VTN is not running"
        self._loop.call_soon_threadsafe(self._server.cancel_event, VEN_ID, event_id)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=30)
