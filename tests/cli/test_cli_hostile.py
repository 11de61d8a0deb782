"""Hostile input through ``napari-labyrinth render``: files, schedulers, batches, signals.

Corrupt, truncated, mislabelled and oversized files each fail in one line
while the rest of a batch renders; a declared-huge file is refused with the
process's peak memory measured; a scheduler that never answers fails within
its timeout; killed and interrupted runs leave no temporary behind.
"""

import http.server
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
import tifffile

import napari_labyrinth
from napari_labyrinth._budget import MEMORY_ENV
from napari_labyrinth.cli import main

#: Where the package these tests import lies (a source tree, or an install of a wheel): the
#: commands they start import the same one.
SRC = str(Path(napari_labyrinth.__file__).resolve().parents[1])

#: Peak RSS (MiB) allowed to the process refusing a declared-huge file: the
#: interpreter with numpy, tifffile and Pillow imported, far below the image.
RSS_CEILING_MIB = 400


def _env(**extra):
    path = os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")]))
    return dict(os.environ, PYTHONPATH=path, **extra)


def declared_huge_tiff(path: Path, size: int = 100_000, tile: int = 4096) -> Path:
    """A deflate-tiled uint8 TIFF declaring ``size`` x ``size`` pixels in a few KB: every
    tile entry points at the same compressed tile of zeros."""
    data = zlib.compress(bytes(tile * tile), 9)
    tiles = (-(-size // tile)) ** 2
    header = 8
    entries = 11
    ifd = header
    ifd_size = 2 + entries * 12 + 4
    offsets_at = ifd + ifd_size
    counts_at = offsets_at + 4 * tiles
    data_at = counts_at + 4 * tiles

    def entry(tag, kind, count, value):
        return struct.pack("<HHII", tag, kind, count, value)

    tags = [
        entry(256, 4, 1, size),  # ImageWidth
        entry(257, 4, 1, size),  # ImageLength
        entry(258, 3, 1, 8),  # BitsPerSample
        entry(259, 3, 1, 8),  # Compression: deflate
        entry(262, 3, 1, 1),  # Photometric: min-is-black
        entry(277, 3, 1, 1),  # SamplesPerPixel
        entry(284, 3, 1, 1),  # PlanarConfiguration
        entry(322, 3, 1, tile),  # TileWidth
        entry(323, 3, 1, tile),  # TileLength
        entry(324, 4, tiles, offsets_at),  # TileOffsets
        entry(325, 4, tiles, counts_at),  # TileByteCounts
    ]
    with open(path, "wb") as file:
        file.write(b"II*\x00" + struct.pack("<I", ifd))
        file.write(struct.pack("<H", entries) + b"".join(tags) + struct.pack("<I", 0))
        file.write(struct.pack(f"<{tiles}I", *([data_at] * tiles)))
        file.write(struct.pack(f"<{tiles}I", *([len(data)] * tiles)))
        file.write(data)
    return path


def run_measured(args, env, timeout=120):
    """Run the CLI in a child process; its exit code, stderr and peak RSS in MiB."""
    wrapper = (
        "import resource, subprocess, sys;"
        "r = subprocess.run(sys.argv[1:], capture_output=True, text=True);"
        "sys.stderr.write(r.stderr);"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss);"
        "sys.exit(r.returncode)"
    )
    command = [sys.executable, "-c", wrapper, sys.executable, "-m", "napari_labyrinth.cli", *args]
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=timeout)
    return done.returncode, done.stderr, int(done.stdout.split()[-1]) / 1024


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.tif"
    tifffile.imwrite(path, np.random.default_rng(0).integers(0, 256, (16, 16), dtype=np.uint8))
    return path


def _errors(capsys):
    return [line for line in capsys.readouterr().err.splitlines() if ": error: " in line]


# -- memory bombs -------------------------------------------------------------------------------------


@pytest.mark.subprocess
def test_a_declared_huge_tiff_is_refused_in_one_line_within_a_memory_ceiling(tmp_path):
    bomb = declared_huge_tiff(tmp_path / "bomb.tif")
    assert bomb.stat().st_size < 100_000
    code, err, peak = run_measured(
        ["render", str(bomb), "-o", str(tmp_path / "out.tif")], _env(**{MEMORY_ENV: "2G"})
    )
    print(f"declared-huge TIFF ({bomb.stat().st_size} B on disk): peak RSS {peak:.0f} MiB")
    lines = [line for line in err.splitlines() if "error" in line]
    assert code == 1 and len(lines) == 1
    assert "declares 100000 x 100000 uint8 pixels (9.3 GiB)" in lines[0]
    assert MEMORY_ENV in lines[0]
    assert peak < RSS_CEILING_MIB
    assert not (tmp_path / "out.tif").exists()


@pytest.mark.slow  # a 900 MB row stream compressed to make the file
def test_a_declared_huge_png_is_refused_before_decoding(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(MEMORY_ENV, "256M")
    path = tmp_path / "wide.png"
    row = b"\x00" + bytes(30_000)
    raw = zlib.compress(row * 30_000, 9)

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    ihdr = struct.pack(">IIBBBBB", 30_000, 30_000, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", raw) + chunk(b"IEND", b"")
    )
    assert main(["render", str(path), "-o", str(tmp_path / "out.png")]) == 1
    (line,) = _errors(capsys)
    assert "declares 30000 x 30000 uint8 pixels" in line


# -- corrupt, truncated, mislabelled files; batches ---------------------------------------------------


def _bad_files(tmp_path, good):
    png = tmp_path / "real.png"
    import imageio.v3 as iio

    iio.imwrite(png, np.zeros((8, 8), np.uint8))
    files = {
        "truncated.tif": good.read_bytes()[:100],
        "corrupt.tif": b"II*\x00" + os.urandom(200),
        "empty.png": b"",
        "text.png": b"not an image at all\n",
        "png_named.jpg": png.read_bytes(),  # mislabelled: pillow reads it anyway
        "tiff_named.png": good.read_bytes(),  # mislabelled: pillow reads TIFF too
        "garbage.bmp": b"BM" + os.urandom(50),
    }
    paths = []
    for name, data in files.items():
        path = tmp_path / name
        path.write_bytes(data)
        paths.append(path)
    return paths


def test_corrupt_truncated_and_mislabelled_files_fail_in_one_line_each_and_the_batch_goes_on(
    tmp_path, good, capsys
):
    bad = _bad_files(tmp_path, good)
    out = tmp_path / "out"
    code = main(["render", *map(str, bad), str(good), "-o", str(out)])
    errors = _errors(capsys)
    failed = {line.split(": error: ")[1].split(":")[0] for line in errors}
    assert code == 1
    assert (out / "good_labyrinth.tif").exists()
    for path in bad:  # each either rendered or failed in exactly one line
        rendered = any(out.glob(f"{path.stem}_labyrinth*"))
        assert rendered != (str(path) in failed), path.name
    assert {"truncated.tif", "corrupt.tif", "empty.png", "text.png"} <= {Path(f).name for f in failed}
    assert all("Traceback" not in line for line in errors)


def test_an_unforeseen_exception_in_one_file_is_one_line_and_the_next_file_renders(
    tmp_path, good, capsys, monkeypatch
):
    from napari_labyrinth import api

    first = tmp_path / "first.tif"
    tifffile.imwrite(first, np.zeros((8, 8), np.uint8))
    real = api.labyrinth_steps

    def steps(image, *args, **kwargs):
        if image.shape == (8, 8):
            raise ZeroDivisionError("float division by zero")
        return real(image, *args, **kwargs)

    monkeypatch.setattr(api, "labyrinth_steps", steps)
    code = main(["render", str(first), str(good), "-o", str(tmp_path / "out")])
    (line,) = _errors(capsys)
    assert code == 1 and "first.tif: ZeroDivisionError: float division by zero" in line
    assert (tmp_path / "out" / "good_labyrinth.tif").exists()


def test_a_constant_huge_float_image_renders_in_a_batch(tmp_path, good, capsys):
    constant = tmp_path / "constant.tif"
    tifffile.imwrite(constant, np.full((2, 16, 16), 1e16, np.float32))
    out = tmp_path / "out"
    assert main(["render", str(constant), str(good), "-o", str(out)]) == 0
    rendered = tifffile.imread(out / "constant_labyrinth.tif")
    assert rendered.dtype == np.float32 and np.isfinite(rendered).all()


def test_a_big_endian_tiff_renders_in_its_values(tmp_path):
    path = tmp_path / "big.tif"
    image = np.random.default_rng(2).integers(0, 4000, (16, 16)).astype(">u2")
    tifffile.imwrite(path, image, byteorder=">")
    assert main(["render", str(path), "-o", str(tmp_path / "out.tif"), "--seed", "3"]) == 0
    from napari_labyrinth import labyrinth

    expected = labyrinth(image.astype(np.uint16), seed=3)
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "out.tif"), expected)


def test_the_alpha_of_a_grey_and_alpha_png_is_kept(tmp_path):
    import imageio.v3 as iio

    rng = np.random.default_rng(3)
    image = np.stack([rng.integers(0, 256, (48, 48)), rng.integers(0, 256, (48, 48))], -1)
    path = tmp_path / "la.png"
    iio.imwrite(path, image.astype(np.uint8))
    assert iio.imread(path).shape == (48, 48, 2)
    # white noise all over: the gate would leave every pixel alone (all of it is noise)
    output = str(tmp_path / "out.png")
    assert main(["render", str(path), "-o", output, "--passes", "3", "--noise-gate", "0"]) == 0
    out = iio.imread(tmp_path / "out.png")
    np.testing.assert_array_equal(out[..., 1], image[..., 1])
    assert not np.array_equal(out[..., 0], image[..., 0])


# -- the scheduler --------------------------------------------------------------------------------------


def _silent_socket():
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    return listener, f"tcp://127.0.0.1:{listener.getsockname()[1]}"


def _http_server():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"tcp://127.0.0.1:{server.server_address[1]}"


@pytest.mark.parametrize("kind", ["silent socket", "HTTP server"])
def test_a_scheduler_that_never_answers_fails_within_the_timeout(kind, tmp_path, good, capsys):
    pytest.importorskip("distributed")
    server, address = _silent_socket() if kind == "silent socket" else _http_server()
    try:
        started = time.monotonic()
        code = main(
            ["render", str(good), "-o", str(tmp_path / "o.tif"), "--scheduler", address,
             "--scheduler-timeout", "1.5"]
        )
        elapsed = time.monotonic() - started
    finally:
        server.close() if kind == "silent socket" else server.shutdown()
    err = capsys.readouterr().err
    print(f"{kind}: failed after {elapsed:.1f} s")
    assert code == 1
    assert f"connecting to the dask scheduler at {address} (timeout 1.5 s)" in err
    assert f"no dask scheduler answered at {address} within 1.5 s" in err
    assert elapsed < 60  # bounded (the timeout, not distributed's endless wait)


@pytest.mark.parametrize("content", ["garbage{", json.dumps({"id": 1}), json.dumps([1, 2])])
def test_a_garbage_scheduler_file_is_named(content, tmp_path, good, capsys):
    pytest.importorskip("distributed")
    path = tmp_path / "scheduler.json"
    path.write_text(content)
    code = main(["render", str(good), "-o", str(tmp_path / "o.tif"), "--scheduler", str(path)])
    (line,) = _errors(capsys)
    assert code == 1 and f"{path} is not a dask scheduler file" in line
    assert "AssertionError" not in line


def test_the_scheduler_timeout_is_checked(tmp_path, good, capsys):
    assert main(["render", str(good), "-o", "x.tif", "--scheduler-timeout", "0"]) == 2
    assert "0 < SECONDS" in capsys.readouterr().err


# -- leftovers: SIGKILL and SIGINT ----------------------------------------------------------------------


def _start_slow_write(tmp_path, output):
    """A CLI run writing a big lazy TIFF stack (slow enough to be signalled mid-write)."""
    stack = tmp_path / "stack.zarr"
    import zarr

    if not stack.exists():
        zarr.create_array(
            store=str(stack), shape=(400, 256, 256), chunks=(1, 256, 256), dtype="u1"
        )
    args = [sys.executable, "-m", "napari_labyrinth.cli", "render", str(stack), "-o",
            str(output), "--passes", "30", "--overwrite"]
    # a shell's background job starts with SIGINT ignored, and Python then keeps it ignored:
    # give the child the default disposition, as a terminal's foreground command has
    child = subprocess.Popen(
        args, env=_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(f".{output.name}.*.tmp")):
        assert child.poll() is None and time.monotonic() < deadline, "the write never started"
        time.sleep(0.05)
    return child


@pytest.mark.subprocess
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("suffix", [".tif", ".zarr"])
def test_sigint_leaves_no_temporary_and_sigkill_leftovers_are_removed_next_time(tmp_path, suffix):
    pytest.importorskip("zarr")
    output = tmp_path / f"out{suffix}"
    child = _start_slow_write(tmp_path, output)
    child.send_signal(signal.SIGINT)
    code = child.wait(timeout=120)
    assert code == 130, child.stderr.read().decode(errors="replace")[-2000:]
    assert not list(tmp_path.glob(f".{output.name}.*")), "SIGINT left a temporary"

    child = _start_slow_write(tmp_path, output)
    child.kill()
    child.wait(timeout=60)
    (left,) = tmp_path.glob(f".{output.name}.*.tmp")  # SIGKILL cannot be cleaned up after
    small = tmp_path / "small.tif"
    tifffile.imwrite(small, np.zeros((8, 8), np.uint8))
    done = subprocess.run(
        [sys.executable, "-m", "napari_labyrinth.cli", "render", str(small), "-o", str(output),
         "--overwrite"], env=_env(), capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert not left.exists() and not list(tmp_path.glob(f".{output.name}.*"))


@pytest.mark.subprocess
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("suffix", [".tif", ".zarr"])
def test_sigterm_is_handled_as_ctrl_c_and_leaves_no_temporary(tmp_path, suffix):
    # what kill, timeout and batch schedulers send: it ended the process at once, leaving
    # the temporary store behind until the next write to the same output
    pytest.importorskip("zarr")
    output = tmp_path / f"out{suffix}"
    child = _start_slow_write(tmp_path, output)
    child.send_signal(signal.SIGTERM)
    code = child.wait(timeout=120)
    err = child.stderr.read().decode(errors="replace")
    assert code == 143, err[-2000:]
    assert "terminated" in err
    assert not output.exists() and not list(tmp_path.glob(f".{output.name}.*"))


def test_sigterm_and_sigint_handlers_are_restored_after_a_command(tmp_path):
    image = tmp_path / "in.tif"
    tifffile.imwrite(image, np.zeros((8, 8), np.uint8))
    assert main(["render", str(image), "-o", str(tmp_path / "out.tif")]) == 0
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.subprocess
@pytest.mark.parametrize("command", ["render", "demo"])
def test_a_closed_stdout_stops_no_batch_and_prints_no_traceback(tmp_path, command):
    # `| head -c 0`: the first output's path met a broken pipe, a traceback, and exit 1
    # before the other files were rendered
    images = []
    for k in range(3):
        images.append(tmp_path / f"in{k}.tif")
        tifffile.imwrite(images[-1], np.full((16, 16), 40 * k, np.uint8))
    out = tmp_path / "out"
    arguments = ["render", *map(str, images), "-o", f"{out}/"]
    if command == "demo":
        arguments = ["demo", "-o", str(out)]
    child = subprocess.Popen(
        [sys.executable, "-m", "napari_labyrinth.cli", *arguments],
        env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    child.stdout.close()  # the reader is gone before the first line
    err = child.stderr.read().decode(errors="replace")
    assert child.wait(timeout=300) == 0, err
    assert "Traceback" not in err and "standard output cannot be written" in err
    written = sorted(out.iterdir())
    assert len(written) == (3 if command == "render" else 8), written


def test_an_output_that_cannot_take_the_rendering_refuses_it_before_it_runs(
    tmp_path, capsys, monkeypatch
):
    # an animated PNG (3-D) into a PNG was rendered whole, then refused by the writer
    from PIL import Image

    from napari_labyrinth import api

    frames = [Image.fromarray(np.full((16, 16), 60 * k, np.uint8)) for k in range(3)]
    source = tmp_path / "anim.png"
    frames[0].save(source, save_all=True, append_images=frames[1:])
    steps = api.labyrinth_steps
    passes = []

    def counted(*args, **kwargs):
        for event in steps(*args, **kwargs):
            passes.append(event)
            yield event

    monkeypatch.setattr(api, "labyrinth_steps", counted)
    assert main(["render", str(source), "-o", str(tmp_path / "out.png")]) == 1
    assert "cannot store uint8 data of shape (3, 16, 16) as PNG" in capsys.readouterr().err
    assert passes == []  # not one pass was rendered
    assert main(["render", str(source), "-o", str(tmp_path / "out.tif")]) == 0


def test_check_output_refuses_as_the_writer_would(tmp_path, monkeypatch):
    from napari_labyrinth import io
    from napari_labyrinth.io import ImageFileError, ImageMetadata, check_output

    check_output(tmp_path / "x.tif", (5, 64, 64), np.uint16, overwrite=False)
    with pytest.raises(ImageFileError, match="as PNG"):
        check_output(tmp_path / "x.png", (5, 64, 64), np.uint8, overwrite=False)
    with pytest.raises(ImageFileError, match="extra samples assocalpha"):
        check_output(
            tmp_path / "x.png", (64, 64, 4), np.uint8, overwrite=False,
            metadata=ImageMetadata(extra_samples=("assocalpha",)),
        )  # fmt: skip
    (tmp_path / "there.tif").write_bytes(b"")
    with pytest.raises(FileExistsError):
        check_output(tmp_path / "there.tif", (8, 8), np.uint8, overwrite=False)
    monkeypatch.setattr(io.os, "access", lambda path, mode: False)  # a read-only mount
    with pytest.raises(PermissionError, match="its directory takes no new file") as raised:
        check_output(tmp_path / "x.tif", (8, 8), np.uint8, overwrite=False)
    assert raised.value.filename == str(tmp_path / "x.tif")  # as the writer's error


class _InterruptedFinaliser:
    """Ctrl-C arriving while the garbage collector runs a finaliser: Python drops it."""

    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(3):  # the handler runs here, inside the finaliser
            time.sleep(0)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("suffix", [".tif", ".zarr"])
def test_an_interrupt_a_finaliser_swallowed_still_stops_the_write(
    tmp_path, suffix, monkeypatch, capsys
):
    import zarr

    from napari_labyrinth.io import tiff as tiff_files
    from napari_labyrinth.io import zarr as zarr_stores

    stack = tmp_path / "stack.zarr"
    zarr.create_array(store=str(stack), shape=(6, 32, 32), chunks=(1, 32, 32), dtype="u1")
    output = tmp_path / f"out{suffix}"
    writer = tiff_files if suffix == ".tif" else zarr_stores  # where the output's blocks run
    run_blocks = writer.run_blocks

    def interrupted_once_started(*args, **kwargs):
        _InterruptedFinaliser()  # collected at once, in the main thread
        return run_blocks(*args, **kwargs)

    monkeypatch.setattr(writer, "run_blocks", interrupted_once_started)
    lost = []  # what Python reports as "Exception ignored in ..."
    monkeypatch.setattr(sys, "unraisablehook", lambda report: lost.append(report.exc_type))
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    code = main(["render", str(stack), "-o", str(output), "--passes", "2"])
    err = capsys.readouterr().err
    assert lost == [KeyboardInterrupt]
    assert code == 130 and "interrupted" in err
    assert not output.exists() and not list(tmp_path.glob(f".{output.name}.*"))
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
