"""Static files of the web console, answered on the WebSocket port (plain HTTP GET/HEAD).

``StaticFiles(root)`` is the ``http_handler`` that ``start_websocket`` calls for a request
without ``Upgrade: websocket``. It serves regular files under ``root`` only: the path is
percent-decoded, hidden components (``.git``, ``..``) are refused, and the resolved file (after
symlinks) must still lie under the resolved root. ``/`` (and any folder) means ``index.html``.
Files are sent with ``Cache-Control: no-cache`` and an ``ETag``, so browsers revalidate and a
``304`` costs no body. Only known file types are served; anything else is ``404``.
"""

from __future__ import annotations

import email.utils
import http
import logging
from collections.abc import Awaitable, Callable
from pathlib import Path
from urllib.parse import unquote

from websockets.datastructures import Headers
from websockets.http11 import Request, Response

from ..session.access import Access

log = logging.getLogger(__name__)

CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".map": "application/json",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    ".ico": "image/x-icon",
    ".txt": "text/plain; charset=utf-8",
}

# The console talks only to its own origin (and, with ?url=, to another bridge over ws/wss);
# roslib decodes png-compressed messages through a data: image.
CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
    "connect-src 'self' ws: wss:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'"
)


# The npm libraries' browser builds the page loads (``npm ci --prefix web``); setup.py ships them.
LIBRARY_FILES = (
    "node_modules/eventemitter2/lib/eventemitter2.js",
    "node_modules/easeljs/lib/easeljs.min.js",
    "node_modules/roslib/build/roslib.min.js",
    "node_modules/ros2d/build/ros2d.min.js",
)


def missing_libraries(root: Path) -> list[str]:
    """The library builds absent under ``root`` (all of them after a pip install without npm)."""
    return [name for name in LIBRARY_FILES if not (root / name).is_file()]


def default_web_root() -> Path | None:
    """The checkout's ``web/`` when running from one, else the copy shipped in the wheel."""
    package = Path(__file__).resolve().parents[1]
    for root in (package.parent / "web", package / "_web"):
        if (root / "index.html").is_file():
            return root
    return None


ROUTINE_HTTP_LOGS = ("HTTP response sent", "connection rejected")


def _plain_http_status(kwargs: dict) -> int | None:
    """The status of the plain HTTP response a connection got (None: a WebSocket, or not
    answered yet); websockets names the connection in the log record's ``extra``."""
    connection = (kwargs.get("extra") or {}).get("websocket")
    try:
        response = getattr(connection, "response", None)
    except ReferenceError:  # a weak proxy to a connection already gone
        return None
    status = getattr(response, "status_code", None)
    return None if status is None or status == 101 else int(status)


class QuietHttpLog(logging.LoggerAdapter):
    """websockets logs every plain HTTP response, and the close of its connection, at INFO
    (~25 lines per page load); a console file served (< 400) is routine, so both go to DEBUG.
    Refusals, errors and WebSocket connections keep their level."""

    def log(self, level, msg, *args, **kwargs):
        if level == logging.INFO and isinstance(msg, str):
            if msg.startswith(ROUTINE_HTTP_LOGS) and args and isinstance(args[0], int):
                status = args[0]
            elif msg == "connection closed":
                status = _plain_http_status(kwargs)
            else:
                status = None
            if status is not None and status < 400:
                level = logging.DEBUG
        super().log(level, msg, *args, **kwargs)


class StaticFiles:
    """An ``http_handler`` serving the files under ``root``."""

    def __init__(self, root: Path | str):
        self.root = Path(root).resolve()

    def resolve(self, raw_path: str) -> Path | None:
        """The file a request path names, or None when it is not one we serve."""
        path = unquote(raw_path.split("?", 1)[0].split("#", 1)[0])
        if not path.startswith("/") or "\\" in path or "\0" in path:
            return None
        parts = [p for p in path.split("/") if p]
        if any(p.startswith(".") for p in parts):
            return None
        candidate = self.root.joinpath(*parts)
        if path.endswith("/") or not parts or candidate.is_dir():
            candidate = candidate / "index.html"
        try:
            candidate = candidate.resolve(strict=True)
        except (OSError, RuntimeError):
            return None
        if not candidate.is_relative_to(self.root) or not candidate.is_file():
            return None
        if candidate.suffix.lower() not in CONTENT_TYPES:
            return None
        return candidate

    def __call__(self, ws, request: Request) -> Response:
        method, file = _lookup(request, self.resolve)
        if isinstance(file, Response):
            return file
        try:
            stat = file.stat()
            body = b"" if method == "HEAD" else file.read_bytes()
        except OSError:
            return _response(404, b"Not found\n", head=method == "HEAD")
        etag = f'"{stat.st_mtime_ns:x}-{stat.st_size:x}"'
        headers = [
            ("Cache-Control", "no-cache"),
            ("ETag", etag),
            ("Last-Modified", email.utils.formatdate(stat.st_mtime, usegmt=True)),
        ]
        match = _etags(request.headers.get("If-None-Match", ""))
        if etag in match or "*" in match:
            return _response(304, b"", headers, head=True, length=False)
        content_type = CONTENT_TYPES[file.suffix.lower()]
        headers.append(("Content-Type", content_type))
        if content_type.startswith("text/html"):
            headers.append(("Content-Security-Policy", CSP))
        return _response(200, body, headers, head=method == "HEAD", size=stat.st_size)


RECORDINGS_PREFIX = "/recordings/"
Page = Callable[[], Awaitable[tuple[int, str, bytes]]]  # made on request: status, type, body


class WithRecordings:
    """The console's files, and where ``GET /recordings/NAME.mcap`` may download from: only
    plain ``*.mcap`` names directly in the recordings folder (no subfolders, no hidden files,
    nothing outside it after symlinks). The download itself is streamed from the file by
    :mod:`.download`, which takes those connections before websockets; what reaches this
    handler under ``/recordings/`` is refused (405 for another method, else 404)."""

    def __init__(self, static: StaticFiles | None, folder: Path | None,
                 pages: dict[str, Page] | None = None, access: Access | None = None):
        """``folder`` None: no downloads. ``pages``: path → what answers it, made on each
        request (``/metrics``, ``/healthz``). ``access``: with ``--authenticate``, the pages
        and downloads answer only a token whose role has their permission (the console's own
        files, which hold no data of the site, are served to all: its sign-in is on them)."""
        self.static = static
        self.folder = folder
        self.pages = pages or {}
        self.access = access or Access()

    def resolve(self, raw_path: str) -> Path | None:
        if self.folder is None or not raw_path.startswith(RECORDINGS_PREFIX):
            return None
        name = unquote(raw_path.split("?", 1)[0].split("#", 1)[0]).removeprefix(RECORDINGS_PREFIX)
        if not name.endswith(".mcap") or name.startswith(".") or any(c in name for c in "/\\\0"):
            return None
        try:
            root = self.folder.resolve(strict=True)
            file = (root / name).resolve(strict=True)
        except (OSError, RuntimeError):
            return None
        return file if file.parent == root and file.is_file() else None

    async def __call__(self, ws, request: Request) -> Response:
        page = self.pages.get(request.path.split("?", 1)[0])
        if page is not None:
            refused = self.refusal(ws, request)
            return refused if refused is not None else await _page(request, page)
        if not request.path.startswith(RECORDINGS_PREFIX):
            if self.static is None:
                return ws.respond(426, "This is a WebSocket endpoint (hitrobot protocol).\n")
            return self.static(ws, request)
        _method, refusal = _lookup(request, lambda _path: None)  # nothing served here
        assert isinstance(refusal, Response)
        return refusal


    def refusal(self, ws, request: Request) -> Response | None:
        """401 or 403 for a request its token does not allow (``--authenticate``)."""
        peer = ws.remote_address[0] if getattr(ws, "remote_address", None) else ""
        refused = self.access.http_refusal(request.path, request.headers.get("Authorization"),
                                           peer)
        if refused is None:
            return None
        status, text = refused
        extra = [("WWW-Authenticate", "Bearer")] if status == 401 else []
        return _response(status, f"{text}\n".encode(), extra)


async def _page(request: Request, page: Page) -> Response:
    """A page made now (no caching), for GET and HEAD."""
    method = getattr(request, "method", "GET")
    if method not in ("GET", "HEAD"):
        return _response(405, b"Method not allowed\n", [("Allow", "GET, HEAD")])
    status, content_type, body = await page()
    return _response(status, body, [("Content-Type", content_type), ("Cache-Control", "no-store")],
                     head=method == "HEAD")


def _lookup(request: Request, resolve: Callable[[str], Path | None]
            ) -> tuple[str, Path | Response]:
    """The request's method and the file it names, or the refusal: 405 for a method other
    than GET/HEAD, 404 when nothing is served at that path."""
    method = getattr(request, "method", "GET")
    if method not in ("GET", "HEAD"):
        return method, _response(405, b"Method not allowed\n", [("Allow", "GET, HEAD")])
    file = resolve(request.path)
    if file is None:
        return method, _response(404, b"Not found\n", head=method == "HEAD")
    return method, file


def _etags(header: str) -> set[str]:
    return {t.strip().removeprefix("W/") for t in header.split(",") if t.strip()}


def _response(status: int, body: bytes, extra: list[tuple[str, str]] = (), *, head: bool = False,
              size: int | None = None, length: bool = True) -> Response:
    code = http.HTTPStatus(status)
    headers = Headers([("Date", email.utils.formatdate(usegmt=True)),
                       ("Connection", "close"),
                       ("X-Content-Type-Options", "nosniff"),
                       ("Referrer-Policy", "no-referrer")])
    if status >= 400:
        headers["Content-Type"] = "text/plain; charset=utf-8"
    for name, value in extra:
        headers[name] = value
    if length:
        headers["Content-Length"] = str(size if size is not None else len(body))
    return Response(code.value, code.phrase, headers, b"" if head else body)
