"""The web console's static files on the WebSocket port: plain HTTP GET/HEAD beside the bridge."""

from __future__ import annotations

import ast
import asyncio
import fnmatch
import logging
import re
from pathlib import Path

import pytest

from hitrobot_server.transport.http import (
    LIBRARY_FILES,
    StaticFiles,
    default_web_root,
    missing_libraries,
)
from tests.helpers import WsClient, until

REPO = Path(__file__).resolve().parents[2]
WEB = REPO / "web"


async def http(port: int, method: str, path: str, headers: dict | None = None):
    """One raw HTTP/1.1 request; returns (status, headers, body)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    lines = [f"{method} {path} HTTP/1.1", f"Host: 127.0.0.1:{port}"]
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    writer.write(("\r\n".join(lines) + "\r\n\r\n").encode())
    await writer.drain()
    raw = await asyncio.wait_for(reader.read(), 10)
    writer.close()
    head, _, body = raw.partition(b"\r\n\r\n")
    status_line, *header_lines = head.decode().split("\r\n")
    status = int(status_line.split()[1])
    got = {}
    for line in header_lines:
        name, _, value = line.partition(":")
        got[name.strip().lower()] = value.strip()
    return status, got, body


async def test_index_and_assets_are_served(server):
    status, headers, body = await http(server.port, "GET", "/")
    assert status == 200
    assert headers["content-type"] == "text/html; charset=utf-8"
    assert body == (WEB / "index.html").read_bytes()
    assert int(headers["content-length"]) == len(body)
    assert headers["cache-control"] == "no-cache" and headers["etag"]
    assert "default-src 'self'" in headers["content-security-policy"]
    assert headers["x-content-type-options"] == "nosniff"

    status, headers, body = await http(server.port, "GET", "/app.js?v=1")
    assert status == 200 and headers["content-type"] == "text/javascript; charset=utf-8"
    assert body == (WEB / "app.js").read_bytes()
    status, headers, _ = await http(server.port, "GET", "/console.css")
    assert status == 200 and headers["content-type"] == "text/css; charset=utf-8"
    status, headers, _ = await http(server.port, "GET", "/favicon.svg")
    assert status == 200 and headers["content-type"] == "image/svg+xml"


async def test_head_and_conditional_get(server):
    status, headers, body = await http(server.port, "HEAD", "/index.html")
    assert status == 200 and body == b""
    assert int(headers["content-length"]) == (WEB / "index.html").stat().st_size
    etag = headers["etag"]
    status, headers, body = await http(server.port, "GET", "/", {"If-None-Match": etag})
    assert status == 304 and body == b"" and headers["etag"] == etag
    status, _, body = await http(server.port, "GET", "/", {"If-None-Match": '"other"'})
    assert status == 200 and body


@pytest.mark.parametrize("path", [
    "/../setup.py", "/%2e%2e/setup.py", "/..%2fsetup.py", "/%2E%2E%2Fpyproject.toml",
    "/app.js/../../setup.py", "//etc/passwd", "/.gitignore", "/nope.js", "/package-lock.jsonx",
    "/web/index.html", "/%00", "/..\\setup.py",
])
async def test_nothing_outside_the_web_root(server, path):
    status, headers, body = await http(server.port, "GET", path)
    assert status == 404, (path, body)
    assert headers["content-type"].startswith("text/plain")


async def test_other_methods_are_refused(server):
    status, headers, _ = await http(server.port, "DELETE", "/index.html")
    assert status == 405 and headers["allow"] == "GET, HEAD"


async def test_websocket_still_answers_on_the_same_port(server):
    client = await WsClient.open(server.port)
    op_id = "get_time"
    await client.send({"op": "call_service", "id": op_id, "service": "/rosapi/get_time"})
    reply = await client.expect(op="service_response", id=op_id)
    assert reply["result"] is True
    await client.close()


def test_symlinks_leaving_the_root_are_refused(tmp_path):
    root = tmp_path / "root"
    root.mkdir()
    (root / "index.html").write_text("<p>hi</p>")
    outside = tmp_path / "secret.txt"
    outside.write_text("secret")
    (root / "link.txt").symlink_to(outside)
    (root / "sub").mkdir()
    (root / "sub" / "index.html").write_text("sub")
    files = StaticFiles(root)
    assert files.resolve("/") == (root / "index.html").resolve()
    assert files.resolve("/sub/") == (root / "sub" / "index.html").resolve()
    assert files.resolve("/sub") == (root / "sub" / "index.html").resolve()
    assert files.resolve("/link.txt") is None
    assert files.resolve("/../secret.txt") is None


def test_checkout_serves_the_repo_web_folder():
    assert default_web_root() == WEB


def page_assets() -> set[str]:
    """Every file the page loads: scripts and links in index.html, then module imports."""
    html = (WEB / "index.html").read_text()
    # (an absolute path such as /foxglove/layout.json is a page the server makes, not a file)
    assets = set(re.findall(r'(?:src|href)="([^":#?/][^":#?]*)"', html))
    todo = [a for a in assets if a.endswith(".js")]
    while todo:
        name = todo.pop()
        for imported in re.findall(r"""^import .* from '\./([^']+)';""",
                                   (WEB / name).read_text(), re.MULTILINE):
            if imported not in assets:
                assets.add(imported)
                todo.append(imported)
    return assets


def test_the_wheel_ships_every_file_the_page_loads():
    """setup.py's WEB_FILES (package data of hitrobot_server._web) covers the page's assets,
    and the npm builds exist after `npm ci --prefix web`."""
    tree = ast.parse((REPO / "setup.py").read_text())
    patterns = next(ast.literal_eval(node.value) for node in ast.walk(tree)
                    if isinstance(node, ast.Assign)
                    and getattr(node.targets[0], "id", "") == "WEB_FILES")
    assets = page_assets()
    assert {"app.js", "console.css", "node_modules/roslib/build/roslib.min.js",
            "node_modules/ros2d/build/ros2d.min.js"} <= assets
    for asset in assets:
        assert (WEB / asset).is_file(), f"{asset} missing: run `npm ci --prefix web`"
        # setuptools globs: '*' does not cross '/'
        assert any(fnmatch.fnmatch(asset, p) and asset.count("/") == p.count("/")
                   for p in patterns), f"{asset} is not shipped by setup.py"


def test_lockfile_names_no_registry_host():
    lock = (WEB / "package-lock.json").read_text()
    assert '"resolved"' not in lock
    assert "registry" not in lock


async def test_served_files_log_at_debug_not_info(server, caplog):
    caplog.set_level(logging.DEBUG, logger="websockets")
    status, _, _ = await http(server.port, "GET", "/index.html")
    assert status == 200
    status, _, _ = await http(server.port, "GET", "/nope.html")
    assert status == 404
    sent = [r for r in caplog.records if "HTTP response sent" in r.getMessage()
            or "connection rejected" in r.getMessage()]
    assert [(r.levelno, r.args[0]) for r in sent] == [(logging.DEBUG, 200), (logging.INFO, 404)]


async def test_start_logs_the_console_url(make_server, caplog):
    caplog.set_level(logging.INFO, logger="hitrobot_server")
    server = await make_server()
    assert f"web console: http://127.0.0.1:{server.port}/" in caplog.text
    assert "libraries are missing" not in caplog.text


async def test_a_web_root_without_npm_libraries_warns_once_at_start(make_server, caplog,
                                                                    tmp_path, monkeypatch):
    """What a `pip install .` without `npm ci --prefix web` ships: the page, no libraries."""
    (tmp_path / "index.html").write_text("<!doctype html><title>console</title>")
    assert missing_libraries(tmp_path) == list(LIBRARY_FILES)
    assert missing_libraries(WEB) == []
    monkeypatch.setattr("hitrobot_server.server.default_web_root", lambda: tmp_path)
    caplog.set_level(logging.INFO, logger="hitrobot_server")
    server = await make_server()
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1
    text = warnings[0].getMessage()
    assert "npm ci --prefix web" in text and "roslib" in text
    status, _, body = await http(server.port, "GET", "/")
    assert status == 200 and b"console" in body


async def test_a_page_load_logs_nothing_at_info(server, caplog):
    """Every file of the console fetched as a browser does: no INFO line from websockets
    (it used to log "connection closed" for each, ~25 a page); at DEBUG each is still there."""
    caplog.set_level(logging.DEBUG, logger="websockets")
    files = ["/", *sorted(f"/{a}" for a in page_assets())]
    for path in files:
        status, _, _ = await http(server.port, "GET", path)
        assert status == 200, path
    await until(
        lambda: sum(r.getMessage() == "connection closed" for r in caplog.records) >= len(files),
        "the server seeing every connection close", 10)
    info = [r.getMessage() for r in caplog.records
            if r.name.startswith("websockets") and r.levelno >= logging.INFO]
    assert info == []
    closed = [r for r in caplog.records if r.getMessage() == "connection closed"]
    assert len(closed) == len(files) and {r.levelno for r in closed} == {logging.DEBUG}


async def test_a_websocket_connection_still_logs_at_info(server, caplog):
    caplog.set_level(logging.INFO, logger="websockets")
    client = await WsClient.open(server.port)
    await client.close()
    await until(lambda: any(r.getMessage() == "connection closed" for r in caplog.records),
                "the server logging the WebSocket's close", 10)
    assert any(r.getMessage() == "connection open" for r in caplog.records)
