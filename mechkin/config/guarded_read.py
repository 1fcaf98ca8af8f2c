"""The one guarded reader of every input file (YAML, URDF/XML, MJCF and the files it includes or
references, CSV tables, sidecars).

Every input goes through :func:`read_bytes` (or, for a file a library opens itself, such as the
files of an MJCF that MuJoCo reads, :func:`check_file` first):

* only regular files: a directory, device (``/dev/zero``), FIFO or socket is refused before a
  byte is read (the file is opened non-blocking, so a FIFO never hangs the open, and checked
  again on the open descriptor, so a file swapped after the check is still refused);
* at most ``limit`` bytes: the size is checked before reading and the read stops one byte past
  the limit (a file that grows while read is refused too), so memory is bounded by the limit;
* a read that stalls (no byte for ``MECHKIN_READ_TIMEOUT`` s, default 30: a hung NFS or FUSE
  file) is given up with one line;
* every problem is one :class:`~mechkin.errors.ConfigError` line naming the file, what it is
  and what is wrong; file contents are never echoed.

Imports: the standard library and errors only.
"""

from __future__ import annotations

import contextlib
import os
import stat
from pathlib import Path
from typing import Any

from mechkin.errors import ConfigError

__all__ = ["MAX_ROBOT_BYTES", "MAX_TABLE_BYTES", "check_file", "env_mib", "read_bytes",
           "read_text"]

#: A robot file (URDF, MJCF and each file it includes); ``MECHKIN_MAX_ROBOT_MB`` raises it.
MAX_ROBOT_BYTES = 64 * 1024 * 1024
#: An input table (an fk motion CSV, a task-space pose list); ``MECHKIN_MAX_TABLE_MB``.
MAX_TABLE_BYTES = 256 * 1024 * 1024


def env_mib(name: str, default: int) -> int:
    """``default`` bytes, or the environment variable ``name`` in MiB when it is a number in
    (0, 1e6)."""
    try:
        mb = float(os.environ.get(name, "") or 0.0)
    except ValueError:
        mb = 0.0
    return int(mb * 1024 * 1024) if 0 < mb < 1e6 else default


def _mib(n: int) -> str:
    return f"{n / 1024 / 1024:.3g} MiB"


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "it is a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _refuse_size(path: Path, what: str, size: int | None, limit: int, hint: str) -> ConfigError:
    got = f"is {size} bytes" if size is not None else "grew while read"
    tail = f" ({hint})" if hint else ""
    return ConfigError(f"{path}: {what} {got}, more than the limit of {limit} bytes "
                       f"({_mib(limit)}){tail}")


def check_file(path: str | os.PathLike[str], *, what: str, limit: int, hint: str = "") -> int:
    """Refuse ``path`` unless it is an existing regular file of at most ``limit`` bytes;
    return its size. For files another library opens by itself."""
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise ConfigError(f"{p}: file not found (the {what})") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{p}: cannot read the {what}: "
                          f"{getattr(exc, 'strerror', None) or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{p}: the {what} is not a regular file ({_kind(st.st_mode)})")
    if st.st_size > limit:
        raise _refuse_size(p, f"the {what}", st.st_size, limit, hint)
    return st.st_size


def read_bytes(path: str | os.PathLike[str], *, what: str, limit: int, hint: str = "") -> bytes:
    """The content of a regular file of at most ``limit`` bytes (ConfigError otherwise)."""
    p = Path(path)
    check_file(p, what=what, limit=limit, hint=hint)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from None
    try:
        mode = os.fstat(fd).st_mode
    except OSError as exc:
        os.close(fd)
        raise ConfigError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(mode):  # swapped between the check and the open
        os.close(fd)
        raise ConfigError(f"{p}: the {what} is not a regular file ({_kind(mode)})")
    return _read_fd(fd, p, what=what, limit=limit, hint=hint)


#: Seconds a read may go without receiving a byte (a stalled NFS or FUSE file, a FIFO whose
#: writer stopped); ``MECHKIN_READ_TIMEOUT`` sets it in (0, 3600].
READ_TIMEOUT_S = 30.0


def read_timeout() -> float:
    """:data:`READ_TIMEOUT_S`, or ``MECHKIN_READ_TIMEOUT`` seconds when in (0, 3600]."""
    try:
        t = float(os.environ.get("MECHKIN_READ_TIMEOUT", "") or READ_TIMEOUT_S)
    except ValueError:
        t = READ_TIMEOUT_S
    return t if 0 < t <= 3600 else READ_TIMEOUT_S


def _read_fd(fd: int, p: Path, *, what: str, limit: int, hint: str = "",
             timeout: float | None = None) -> bytes:
    """Read ``fd`` (closed here) to its end, at most ``limit`` bytes, giving up when no byte
    arrives for ``timeout`` seconds (:func:`read_timeout`). The reads run in a daemon thread:
    a read blocked in the kernel (a hung network file system) cannot be interrupted, so the
    caller stops waiting for it, and the thread closes the descriptor if it ever returns."""
    import select
    import threading
    import time

    timeout = read_timeout() if timeout is None else timeout
    state: dict[str, Any] = {"chunks": [], "got": 0, "last": time.monotonic(), "stop": False}

    def reader() -> None:
        try:
            while state["got"] <= limit and not state["stop"]:
                try:
                    b = os.read(fd, min(1 << 20, limit + 1 - state["got"]))
                except BlockingIOError:  # a non-blocking pipe without data: wait for some
                    select.select([fd], [], [], 0.1)
                    continue
                if not b:
                    break
                state["chunks"].append(b)
                state["got"] += len(b)
                state["last"] = time.monotonic()
        except OSError as exc:
            state["error"] = exc
        finally:
            os.close(fd)

    th = threading.Thread(target=reader, daemon=True, name="mechkin-read")
    th.start()
    while True:
        th.join(min(0.5, timeout))
        if not th.is_alive():
            break
        idle = time.monotonic() - state["last"]
        if idle > timeout:
            state["stop"] = True
            raise ConfigError(f"{p}: reading the {what} stalled: no data for {timeout:g} s "
                              f"after {state['got']} bytes (a hung file system or pipe?); "
                              "MECHKIN_READ_TIMEOUT sets the wait")
    if "error" in state:
        exc = state["error"]
        raise ConfigError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from None
    if state["got"] > limit:
        raise _refuse_size(p, f"the {what}", None, limit, hint)
    return b"".join(state["chunks"])


def read_text(path: str | os.PathLike[str], *, what: str, limit: int, hint: str = "") -> str:
    """:func:`read_bytes` decoded as UTF-8 (a BOM dropped); a bad byte is a located error."""
    raw = read_bytes(path, what=what, limit=limit, hint=hint)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(f"{Path(path)}:{line}: the {what} is not UTF-8 text (byte "
                          f"{exc.start}: {exc.reason})") from None


def read_head(path: str | os.PathLike[str], n: int) -> str:
    """The first ``n`` bytes of a regular file as text (to sniff its kind); "" for anything
    else (a FIFO, a device, a missing file): the reader then refuses it with its own line."""
    p = Path(path)
    try:
        if not stat.S_ISREG(os.stat(p).st_mode):
            return ""
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except (OSError, ValueError):
        return ""
    try:
        return os.read(fd, n).decode("utf-8", errors="replace") if stat.S_ISREG(
            os.fstat(fd).st_mode) else ""
    except OSError:
        return ""
    finally:
        os.close(fd)


def robot_limit() -> int:
    """The size limit of a robot file: :data:`MAX_ROBOT_BYTES` or ``MECHKIN_MAX_ROBOT_MB``."""
    return env_mib("MECHKIN_MAX_ROBOT_MB", MAX_ROBOT_BYTES)


def read_robot_xml(path: str | os.PathLike[str], what: str) -> bytes:
    """A robot XML file (URDF, MJCF) through :func:`read_bytes` with :func:`robot_limit`."""
    return read_bytes(path, what=what, limit=robot_limit(),
                      hint="MECHKIN_MAX_ROBOT_MB raises the limit")


#: Joints (URDF ``<joint>``, MJCF ``<body>``) a robot file may hold: a 10,000-link URDF takes
#: about 360 MB and 20 s to import; ``MECHKIN_MAX_ROBOT_JOINTS`` raises it.
MAX_ROBOT_JOINTS = 20_000
MAX_INCLUDES = 256
_ASSET_ATTRS = {"mesh": ("file",), "skin": ("file",), "hfield": ("file",),
                "texture": ("file", "fileright", "fileleft", "fileup", "filedown", "filefront",
                            "fileback")}


def max_robot_joints() -> int:
    try:
        n = int(float(os.environ.get("MECHKIN_MAX_ROBOT_JOINTS", "") or MAX_ROBOT_JOINTS))
    except (ValueError, OverflowError):
        n = MAX_ROBOT_JOINTS
    return n if 0 < n < 10**7 else MAX_ROBOT_JOINTS


def check_count(path: str | os.PathLike[str], what: str, n: int) -> None:
    """Refuse a robot file of more than :func:`max_robot_joints` ``what`` elements."""
    cap = max_robot_joints()
    if n > cap:
        raise ConfigError(f"{Path(path)}: {n} {what} elements, more than the limit of {cap} "
                          "(MECHKIN_MAX_ROBOT_JOINTS raises it)")


def check_mjcf_files(path: str | os.PathLike[str]) -> str:
    """Check an MJCF file and every file it includes or references (meshes, textures, height
    fields, skins) before MuJoCo opens them: regular files within the limits, at most
    :data:`MAX_INCLUDES` includes, at most :func:`max_robot_joints` bodies. Returns the main
    file's text (for line numbers)."""
    import xml.etree.ElementTree as ET

    main = Path(path)
    raw = read_robot_xml(main, "MJCF file")
    text = raw.decode("utf-8", errors="replace")
    base = main.parent
    try:
        root = ET.fromstring(raw)
    except ET.ParseError:
        return text  # MuJoCo reports the syntax error with its line
    dirs = {"mesh": "", "texture": ""}
    for c in root.iter("compiler"):
        asset = c.get("assetdir", "")
        dirs["mesh"] = c.get("meshdir", asset) or dirs["mesh"]
        dirs["texture"] = c.get("texturedir", asset) or dirs["texture"]
    queue, seen, bodies = [(main, root)], 0, 0
    while queue:
        where, el_root = queue.pop()
        for el in el_root.iter():
            if el.tag == "body":
                bodies += 1
            elif el.tag == "include" and el.get("file"):
                seen += 1
                if seen > MAX_INCLUDES:
                    raise ConfigError(f"{where}: more than {MAX_INCLUDES} <include> files")
                inc = base / el.get("file", "")
                data = read_robot_xml(inc, "MJCF include file")
                with contextlib.suppress(ET.ParseError):  # MuJoCo reports it
                    queue.append((inc, ET.fromstring(data)))
            elif el.tag in _ASSET_ATTRS:
                sub = dirs["mesh"] if el.tag != "texture" else dirs["texture"]
                for attr in _ASSET_ATTRS[el.tag]:
                    if el.get(attr) and not os.path.lexists(base / sub / el.get(attr, "")):
                        continue  # missing on disk: mechkin.config.mjcf compiles without it
                    if el.get(attr):
                        check_file(base / sub / el.get(attr, ""), what=f"MJCF {el.tag} file",
                                   limit=4 * robot_limit(),
                                   hint="MECHKIN_MAX_ROBOT_MB raises the limit")
    check_count(main, "<body>", bodies)
    return text


def redirect_mujoco_log(mujoco: Any) -> None:
    """Send MuJoCo's warnings to mechkin's log (debug) instead of its default handler, which
    appends them to ``MUJOCO_LOG.TXT`` in the working directory."""
    import logging

    log = logging.getLogger("mechkin.mujoco")
    with contextlib.suppress(Exception):
        if mujoco.get_mju_user_warning() is None:
            mujoco.set_mju_user_warning(lambda msg: log.debug("MuJoCo: %s", msg))
