"""The estimate as a Parquet file: the columns of the CSV output, written chunk by chunk, whole or absent.

``omegahat estimate LOG -o omega.parquet`` writes ``t, wx, wy, wz`` (float64: s, rad/s in body axes) and ``status``
(the words of :mod:`omegahat.io.output`, dictionary-encoded: a categorical column in pandas, an enum-like string
column in Polars), one row group per chunk of the input. The file is written and published as the CSV is (a
temporary file beside the target, renamed when complete; :class:`omegahat.io.output.OmegaWriter`): only the format
of the bytes differs. Parquet keeps every bit of the floats; the file's size and the time to write it against the
CSV's: ``benchmarks/big_log.py``.
"""

from __future__ import annotations

import pyarrow as pa
import pyarrow.parquet as pq

from omegahat.io.output import OmegaWriter

__all__ = ["SCHEMA", "ParquetOmegaWriter"]

SCHEMA = pa.schema(
    [
        ("t", pa.float64()),
        ("wx", pa.float64()),
        ("wy", pa.float64()),
        ("wz", pa.float64()),
        ("status", pa.dictionary(pa.int8(), pa.string())),
    ]
)


class ParquetOmegaWriter(OmegaWriter):
    """:class:`~omegahat.io.output.OmegaWriter`'s rows as Parquet (module docstring): one row group per chunk."""

    def _begin(self) -> None:
        self._parquet = pq.ParquetWriter(self._f, SCHEMA)

    def _put(self, table: pa.Table) -> None:
        self._parquet.write_table(table)

    def _end(self) -> None:
        self._parquet.close()  # the footer; the file itself stays open for the flush and the rename

    def abort(self) -> None:
        """As the CSV's: the temporary file removed. The Parquet writer is marked closed first, so that it never
        writes its footer into the discarded file (nor, when collected, into a closed one)."""
        parquet = getattr(self, "_parquet", None)
        if parquet is not None:
            parquet.is_open = False  # its close() writes the footer only while open; a chunk in flight ends first
        super().abort()

    def describe(self) -> str:
        """What was written, for the command's closing line."""
        return super().describe().replace("(t,wx,wy,wz,status;", "(Parquet: t,wx,wy,wz,status;", 1)
