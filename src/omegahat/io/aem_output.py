r"""The estimate written back as a CCSDS attitude ephemeris message: ``omegahat estimate in.aem -o out.aem``.

An AEM in (:mod:`omegahat.io.aem`) gives an AEM out of type ``QUATERNION/ANGVEL`` (version 2.0): each epoch's
attitude as read, from the external frame to the spacecraft's (``REF_FRAME_A`` the external frame, ``REF_FRAME_B``
the spacecraft's, quaternion :math:`(q_1, q_2, q_3, q_c)`, scalar last: by (A2) the quaternion of omegahat's
:math:`R`), and the estimated angular velocity in the spacecraft frame's axes (``ANGVEL_FRAME``) in **deg/s**, as
the standard writes rates. The epochs are the input's, to the nanosecond, in its ``TIME_SYSTEM``; the object's
name and identifier are copied. Tools that read AEMs (Orekit, GMAT, omegahat itself) then have the rates beside
the attitudes, e.g. for Hermite interpolation.

A sample without an attitude (a missing one) or without an estimate (``unavailable``, ``restarted``) has no line:
the standard has no empty values. How many were left out is said in a ``COMMENT`` of the file and in the command's
closing line. The file is whole or absent (:class:`omegahat.io.output.OmegaWriter`'s temporary file and rename);
its data lines wait in a spooled temporary file until the last, since the metadata's ``STOP_TIME`` comes first.
"""

from __future__ import annotations

import datetime
import os
import shutil
import tempfile

import numpy as np

from omegahat.io.aem import epoch_text
from omegahat.io.output import OmegaWriter
from omegahat.io.registry import LogChunk, LogStream

__all__ = ["AemWriter", "open_aem_output"]

_SPOOL_BYTES = 16 << 20  # data lines kept in memory up to this size, then in a temporary file


class AemWriter(OmegaWriter):
    """An AEM of the attitudes and the estimated rates (module docstring)."""

    def __init__(self, path: str | os.PathLike[str], stream: LogStream):
        self.aem = dict(stream.meta["aem"])
        self.source = stream.source
        self._spool = tempfile.SpooledTemporaryFile(max_size=_SPOOL_BYTES, mode="w+b")
        self.left_out = 0
        self._span: list[int] = []
        super().__init__(path, t0=0.0)

    def _begin(self) -> None:
        """The header waits for the last chunk (its ``STOP_TIME``)."""

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None:
        """Spool the lines of the samples with an attitude and an estimate (module docstring)."""
        q = np.asarray(chunk.data, dtype=float).reshape(len(chunk), -1)
        keep = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(omega), axis=1)
        ns = self.aem["base_ns"] + np.round(np.asarray(chunk.t, dtype=float) * 1e9).astype(np.int64)
        degrees = np.degrees(omega)
        text = "".join(
            epoch_text(int(ns[k])) + " " + " ".join(f"{v:.16g}" for v in (*q[k], *degrees[k])) + "\n"
            for k in np.flatnonzero(keep)
        )
        if keep.any():
            kept = ns[keep]
            self._span = [int(kept[0]) if not self._span else self._span[0], int(kept[-1])]
        self._wait()
        assert self._pool is not None
        self._pending = self._pool.submit(self._spool.write, text.encode())
        self.rows += int(keep.sum())
        self.left_out += int((~keep).sum())

    def _end(self) -> None:
        assert self._f is not None
        if not self._span:
            raise ValueError(f"{self.path}: no sample has both an attitude and an estimate: an AEM cannot be written")
        a = self.aem
        now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%S")
        head = [
            "CCSDS_AEM_VERS = 2.0",
            f"CREATION_DATE = {now}",
            "ORIGINATOR = omegahat",
            "",
            "META_START",
            f"COMMENT angular velocity estimated by omegahat from the attitudes of {os.path.basename(self.source)}",
        ]
        if self.left_out:
            head.append(f"COMMENT {self.left_out} samples without an attitude or an estimate are left out")
        head += [
            f"{key} = {a[key.lower()]}" for key in ("OBJECT_NAME", "OBJECT_ID", "CENTER_NAME") if a.get(key.lower())
        ]
        head += [
            f"REF_FRAME_A = {a['external']}",
            f"REF_FRAME_B = {a['craft']}",
            f"TIME_SYSTEM = {a['system']}",
            f"START_TIME = {epoch_text(self._span[0])}",
            f"STOP_TIME = {epoch_text(self._span[1])}",
            "ATTITUDE_TYPE = QUATERNION/ANGVEL",
            f"ANGVEL_FRAME = {a['craft']}",
            "META_STOP",
            "",
            "DATA_START",
        ]
        self._f.write(("\n".join(head) + "\n").encode())
        self._spool.seek(0)
        shutil.copyfileobj(self._spool, self._f)
        self._f.write(b"DATA_STOP\n")
        self._spool.close()

    def abort(self) -> None:
        super().abort()
        self._spool.close()

    def describe(self) -> str:
        """What was written, for the command's closing line."""
        left = f"; {self.left_out} samples without an attitude or an estimate left out" if self.left_out else ""
        return (
            f"{self.rows} epochs to {self.path} (CCSDS AEM 2.0, QUATERNION/ANGVEL: the attitudes and the rates in "
            f"deg/s, {self.aem['craft']} axes){left}{self.stale_note()}"
        )


def open_aem_output(path: str | os.PathLike[str], stream: LogStream) -> AemWriter:
    """The :class:`AemWriter` of an AEM stream's estimates (the opener of the writers' registry)."""
    return AemWriter(path, stream)
