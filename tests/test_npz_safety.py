"""Issue 23, NPZ logs: a member that is not a ``.npy`` array, a header that claims more than the file holds, and an
archive that expands to more than omegahat reads are refused with a message, before anything is allocated or
decompressed; every message names the file and the array."""

from __future__ import annotations

import io
import struct
import time
import tracemalloc
import zipfile

import numpy as np
import pytest

from logmaker import constant_rate
from omegahat.io import LogFormatError, npzlog, read_log

T = 100


def npy_header(shape, descr="<f8") -> bytes:
    """A version 1.0 ``.npy`` header for ``shape`` (the format's specification: magic, version, little-endian
    header length, a dict literal padded with spaces to a multiple of 64 bytes, ending in a newline)."""
    text = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {tuple(shape)!r}, }}"
    pad = 64 - (10 + len(text) + 1) % 64
    text += " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode("latin1")


def npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def good_arrays():
    t = np.arange(T) / 100.0
    return t, constant_rate(t, np.array([0.1, -0.2, 0.3])).as_quat()


def archive(path, members: dict[str, bytes], compression=zipfile.ZIP_STORED):
    with zipfile.ZipFile(path, "w", compression=compression) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return path


def test_a_member_that_is_not_an_npy_array(tmp_path):
    t, _ = good_arrays()
    p = archive(tmp_path / "x.npz", {"t.npy": npy(t), "q.npy": b"hello world, not an npy"})
    with pytest.raises(LogFormatError, match=r"x\.npz, array q: not a NumPy \.npy array \(it starts with b'hello wo"):
        read_log(p)


def test_other_members_are_ignored_like_other_columns(tmp_path):
    t, q = good_arrays()
    p = archive(tmp_path / "x.npz", {"t.npy": npy(t), "q.npy": npy(q), "readme.txt": b"recorded on the roof"})
    np.testing.assert_array_equal(read_log(p).data, q)


def test_a_header_claiming_1e12_elements_is_refused_before_allocating(tmp_path):
    t, _ = good_arrays()
    p = archive(tmp_path / "x.npz", {"t.npy": npy(t), "q.npy": npy_header((250_000_000_000, 4)) + bytes(64)})
    with pytest.raises(LogFormatError, match=r"x\.npz, array q: expected shape \(100, 4\), got \(250000000000, 4\)"):
        read_log(p)
    p = archive(tmp_path / "y.npz", {"t.npy": npy_header((1_000_000_000_000,)) + bytes(64), "q.npy": npy(t)})
    with pytest.raises(
        LogFormatError,
        match=r"y\.npz, array t: damaged: its header says shape \(1000000000000,\) of float64 \(8000000000000 bytes\) "
        r"but the archive holds 64 bytes for it",
    ):
        read_log(p)


def test_an_archive_that_expands_beyond_the_limit_is_refused_before_decompressing(tmp_path, monkeypatch):
    # A real bomb, scaled down: zeros that deflate about 1000:1, refused from the sizes the archive and the array's
    # header state, before a byte of the array is decompressed.
    monkeypatch.setattr(npzlog, "MAX_NPZ_BYTES", 8_000_000)
    n = 4_000_000
    header = npy_header((n,))
    p = tmp_path / "bomb.npz"
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        with z.open("t.npy", "w") as f:
            f.write(header)
            f.write(bytes(8 * n))
        z.writestr("q.npy", npy(np.zeros((n, 4))[:1]))
    assert p.stat().st_size < 100_000
    tracemalloc.start()
    start = time.process_time()
    with pytest.raises(
        LogFormatError,
        match=r"bomb\.npz, array t: 32 MB \(shape \(4000000,\) of float64\) with the arrays before it would be 32 MB "
        r"in memory; omegahat reads at most 8 MB of arrays from an NPZ log \(it is read whole\): split the log, "
        r"or write it as CSV \(read in chunks\)",
    ):
        read_log(p)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000 and time.process_time() - start < 1.0


def test_members_compressed_as_numpy_never_does_are_refused_before_decompressing(tmp_path):
    # zipfile bounds the output of one read of a deflated member, not of a bzip2 or LZMA one: a 1.6 kB bzip2
    # member of 2.1 GB of zeros used to take 4 GB of memory for its first bytes
    t, q = good_arrays()
    for method, word in ((zipfile.ZIP_BZIP2, "bzip2"), (zipfile.ZIP_LZMA, "LZMA")):
        p = archive(tmp_path / "x.npz", {"t.npy": npy(t), "q.npy": npy(q)}, compression=method)
        with pytest.raises(LogFormatError, match=rf"x\.npz, array t: compressed with method {method} \({word}\)"):
            read_log(p)
    p = archive(tmp_path / "x.npz", {"t.npy": npy(t), "q.npy": npy(q)}, compression=zipfile.ZIP_DEFLATED)
    np.testing.assert_array_equal(read_log(p).data, q)  # numpy.savez_compressed's


def test_the_limit_counts_every_array_read(tmp_path, monkeypatch):
    t, q = good_arrays()
    np.savez(tmp_path / "x.npz", t=t, q=q)
    monkeypatch.setattr(npzlog, "MAX_NPZ_BYTES", 8 * T + 32 * T - 1)  # t fits, t and q do not
    with pytest.raises(LogFormatError, match=r"x\.npz, array q: 3.2 kB .* with the arrays before it would be 4 kB"):
        read_log(tmp_path / "x.npz")
    monkeypatch.setattr(npzlog, "MAX_NPZ_BYTES", 8 * T + 32 * T)
    np.testing.assert_array_equal(read_log(tmp_path / "x.npz").data, q)


def test_the_default_limit_is_in_the_message_and_large_enough_for_real_logs():
    assert npzlog.MAX_NPZ_BYTES >= 1 << 30  # 16 M samples of t, q and tau


@pytest.mark.parametrize(
    ("members", "match"),
    [
        ({"t.npy": "complex"}, r"array t: expected real numbers, got dtype complex128"),
        ({"t.npy": "object"}, r"array t: .*(pickle|object)"),
        ({"t.npy": "crc"}, r"array t: cannot be read \(Bad CRC-32"),
        ({"t.npy": "v3"}, r"array t: "),
    ],
)
def test_damaged_or_unusual_members_give_messages(tmp_path, members, match):
    t, q = good_arrays()
    kind = members["t.npy"]
    if kind == "complex":
        data = npy(t.astype(complex))
    elif kind == "object":
        data = npy_header((T,), "|O") + bytes(8 * T)
    elif kind == "v3":
        data = bytearray(npy(t))
        data[6] = 3
        data = bytes(data)
    else:
        data = npy(t)
    p = archive(tmp_path / "x.npz", {"t.npy": data, "q.npy": npy(q)})
    if kind == "crc":
        raw = bytearray(p.read_bytes())
        k = raw.index(npy(t)[200:216])  # a byte of t's data, stored uncompressed
        raw[k] ^= 0xFF
        p.write_bytes(bytes(raw))
    with pytest.raises(LogFormatError, match=r"x\.npz, " + match):
        read_log(p)


def test_a_single_array_file_is_not_a_log(tmp_path):
    p = tmp_path / "x.npz"
    p.write_bytes(npy(np.zeros(3)))
    with pytest.raises(LogFormatError, match=r"x\.npz: not a readable \.npz file \(it holds a single array"):
        read_log(p)


def test_big_endian_and_fortran_order_arrays_read_as_their_values(tmp_path):
    t, q = good_arrays()
    np.savez(tmp_path / "x.npz", t=t.astype(">f8"), q=np.asfortranarray(q).astype(">f4"))
    log = read_log(tmp_path / "x.npz")
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.data, q.astype(">f4").astype(float))
