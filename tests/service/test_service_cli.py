"""`hvacflex serve` and its subcommands on bad input (exit 2, a message naming the option,
no traceback), and a real server over TLS on 127.0.0.1 with a throwaway self-signed
certificate, printing its URL and logging JSON."""

from __future__ import annotations

import json
import shutil
import ssl
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from service_fixtures import SERVE, free_port
from typer.testing import CliRunner

from hvacflex.cli import app as cli

RUNNER = CliRunner()


def _bad_input_cases(tmp: Path) -> list[tuple[list[str], str]]:
    (tmp / "binary.db").write_bytes(bytes(range(256)) * 64)
    missing = tmp / "no-such-folder" / "service.db"
    return [
        (["serve", "--db", "not-a-url"], "not a database URL"),
        (["serve", "--db", f"sqlite:///{missing}"], "folder of the SQLite file does not exist"),
        (["serve", "--db", f"sqlite:///{tmp / 'binary.db'}"], "cannot open the database"),
        (["serve", "--db", "postgresql+psycopg://hvacflex@127.0.0.1:1/hvacflex"], "field 'db'"),
        (["serve", "key", "create", "--role", "operator", "--db", "nope://x"], "field 'db'"),
        (["serve", "key", "list", "--db", f"sqlite:///{missing}"], "does not exist"),
        (["serve", "replay", "--url", "http://127.0.0.1:1"], "field '--key-file'"),
        (["serve", "replay", "--url", "not a url"], "not an http(s) URL"),
        (["serve", "replay", "--url", "http://127.0.0.1:99999"], "field '--url'"),
        (["serve", "replay", "--url", "ftp://127.0.0.1/"], "not an http(s) URL"),
        (["serve", "replay", "--url", "http://x", "--key-file", str(tmp / "none")], "key file"),
        (["serve", "--host", "999.1.1.1"], "not an IPv4 address"),
        (["serve", "--ssl-certfile", str(tmp / "none.pem")], "needs both"),
        (["serve", "--stale-after-s", "nan"], "--stale-after-s"),
        (["serve", "--log-level", "loud"], "--log-level"),
        (["serve", "--host", "0.0.0.0"], "--insecure-http"),
        (["serve", "--host", "0.0.0.0", "--port", "8443"], "--ssl-certfile"),
        (["serve", "--ssl-min-version", "1.1"], "--ssl-min-version"),
        (["serve", "--clock-limit", "0/10"], "--clock-limit"),
        (["serve", "--register-limit", "ten/3600"], "--register-limit"),
    ]


@pytest.mark.parametrize("case", range(20))
def test_bad_input_exits_2_with_a_message(tmp_path: Path, case: int) -> None:
    args, expected = _bad_input_cases(tmp_path)[case]
    result = RUNNER.invoke(cli, args, env={"HVACFLEX_KEY": ""})
    assert result.exit_code == 2, (args, result.output, result.exception)
    assert isinstance(result.exception, SystemExit)
    assert "Traceback" not in result.output
    assert expected in result.output and result.output.startswith("error: "), result.output


def test_replay_to_a_closed_port_exits_2(tmp_path: Path) -> None:
    result = RUNNER.invoke(
        cli,
        [
            "serve",
            "replay",
            "--url",
            f"http://127.0.0.1:{free_port()}",
            "--days",
            "0.5",
            "--out",
            str(tmp_path / "out"),
        ],
        env={"HVACFLEX_KEY": "hvf_0123456789abcdef_secret"},
    )
    assert result.exit_code == 2, result.output
    assert "cannot reach the service" in result.output and "Traceback" not in result.output


def test_replay_to_an_output_file_exits_2(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x")
    result = RUNNER.invoke(
        cli,
        ["serve", "replay", "--url", "http://127.0.0.1:1", "--out", str(tmp_path / "file" / "o")],
        env={"HVACFLEX_KEY": "hvf_0123456789abcdef_secret"},
    )
    assert result.exit_code == 2 and "field '--out'" in result.output, result.output


def _self_signed(folder: Path) -> tuple[Path, Path]:
    cert, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            "1",
            "-subj",
            "/CN=127.0.0.1",
            "-addext",
            "subjectAltName=IP:127.0.0.1",
            "-keyout",
            str(key),
            "-out",
            str(cert),
        ],
        check=True,
        capture_output=True,
        timeout=60,
    )
    return cert, key


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")
def test_serve_over_tls_prints_its_url_and_logs_json(tmp_path: Path) -> None:
    cert, key = _self_signed(tmp_path)
    port = free_port()
    process = subprocess.Popen(
        [
            *SERVE,
            "--db",
            f"sqlite:///{tmp_path / 'tls.db'}",
            "--port",
            str(port),
            "--ssl-certfile",
            str(cert),
            "--ssl-keyfile",
            str(key),
            "--ssl-min-version",
            "1.3",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None and process.stderr is not None
        first = process.stdout.readline()
        assert f"https://127.0.0.1:{port}/" in first, first
        context = ssl.create_default_context(cafile=str(cert))
        deadline, answer = time.monotonic() + 60, None
        while answer is None and time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(
                    f"https://127.0.0.1:{port}/v1/health", context=context, timeout=5
                ) as response:
                    answer = json.loads(response.read())
            except OSError:
                time.sleep(0.3)
        assert answer is not None and answer["status"] == 200
        tls12_only = ssl.create_default_context(cafile=str(cert))
        tls12_only.maximum_version = ssl.TLSVersion.TLSv1_2
        with pytest.raises(urllib.error.URLError) as refused:  # below --ssl-min-version 1.3
            urllib.request.urlopen(
                f"https://127.0.0.1:{port}/v1/health", context=tls12_only, timeout=5
            )
        assert isinstance(refused.value.reason, ssl.SSLError)  # no handshake
        with pytest.raises(OSError):  # the certificate is not trusted by default
            urllib.request.urlopen(f"https://127.0.0.1:{port}/v1/health", timeout=5)
        with pytest.raises(OSError):  # plain HTTP is not served
            urllib.request.urlopen(f"http://127.0.0.1:{port}/v1/health", timeout=5)
    finally:
        process.terminate()
        _, stderr = process.communicate(timeout=30)
    logged = [json.loads(line) for line in stderr.splitlines() if line.startswith("{")]
    health = [e for e in logged if e.get("route") == "/v1/health" and e.get("status") == 200]
    assert health and health[0]["logger"] == "hvacflex.service.access"
    assert all(line.startswith("{") for line in stderr.splitlines() if line.strip()), stderr


def test_serve_plain_http_on_all_addresses_only_when_told(tmp_path: Path) -> None:
    """``--insecure-http`` lets plain HTTP listen beyond loopback (behind a TLS proxy)."""
    port = free_port()
    process = subprocess.Popen(
        [
            *SERVE,
            "--db",
            f"sqlite:///{tmp_path / 'plain.db'}",
            "--host",
            "0.0.0.0",
            "--port",
            str(port),
            "--insecure-http",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        first = process.stdout.readline()
        assert f"http://0.0.0.0:{port}/" in first, first
    finally:
        process.terminate()
        process.communicate(timeout=30)
