"""The XML form of a CCSDS attitude ephemeris message (``<aem id="CCSDS_AEM_VERS" version="...">``), turned into
the segments of the text form, so that :mod:`omegahat.io.aem` reads both the same way.

Each ``<segment>`` gives its ``<metadata>`` children as keywords (``REF_FRAME_A``, ``ATTITUDE_TYPE`` ...) and each
``<attitudeState>`` of its ``<data>`` one row: the ``EPOCH``, then the numbers in the order the text form writes
them, found **by their element names**: ``Q1 Q2 Q3 QC`` (so ``QUATERNION_TYPE`` is ``LAST`` whatever the file says;
XML names the scalar), then ``Q1_DOT .. QC_DOT``, or ``ANGVEL_X .. ANGVEL_Z``, or the version 1.0 rates named by
their ``rate`` attribute (``X_RATE`` ...), or ``SPIN_ALPHA SPIN_DELTA SPIN_ANGLE SPIN_ANGLE_VEL``. Euler angles,
whose XML names their axes rather than their place in the sequence, are refused with a message (write the text
form). Rows are labelled by the line of their ``<attitudeState>`` (Expat's line numbers), so messages name lines.
"""

from __future__ import annotations

from xml.parsers import expat

from omegahat.io.columns import LogFormatError

__all__ = ["FIELDS", "xml_segments"]

_QUATERNION = ("Q1", "Q2", "Q3", "QC")
#: attitude type -> the element names of a state's numbers, in the text form's order
FIELDS = {
    "QUATERNION": _QUATERNION,
    "QUATERNION/DERIVATIVE": (*_QUATERNION, "Q1_DOT", "Q2_DOT", "Q3_DOT", "QC_DOT"),
    "QUATERNION/RATE": (*_QUATERNION, "X_RATE", "Y_RATE", "Z_RATE"),
    "QUATERNION/ANGVEL": (*_QUATERNION, "ANGVEL_X", "ANGVEL_Y", "ANGVEL_Z"),
    "SPIN": ("SPIN_ALPHA", "SPIN_DELTA", "SPIN_ANGLE", "SPIN_ANGLE_VEL"),
}

Segments = list[tuple[int, dict[str, str], list[tuple[int, list[str]]]]]


class _Reader:
    """Expat's events gathered into segments (module docstring)."""

    def __init__(self, path: str, parser: expat.XMLParserType):
        self.path, self.parser = path, parser
        self.version = ""
        self.segments: Segments = []
        self.stack: list[str] = []
        self.text: list[str] = []
        self.state: tuple[int, dict[str, str]] | None = None  # (line, its values by name)
        self.name = ""  # the current leaf's name (its rate/angle attribute where it has one)

    def start(self, tag: str, attrs: dict[str, str]) -> None:
        line = self.parser.CurrentLineNumber
        if tag == "aem":
            self.version = attrs.get("version", "")
        elif tag == "segment":
            self.segments.append((line, {}, []))
        elif tag == "attitudeState":
            self.state = (line, {})
        elif tag.startswith("rotation") and "angle" in attrs:
            raise LogFormatError(
                f"{self.path}, line {line}: Euler angles in the XML form are not read (their elements name axes, "
                "not places in the sequence); write the AEM in its text form"
            )
        self.stack.append(tag)
        self.name = attrs.get("rate", tag)
        self.text = []

    def end(self, tag: str) -> None:
        self.stack.pop()
        value = "".join(self.text).strip()
        self.text = []
        parent = self.stack[-1] if self.stack else ""
        if parent == "metadata" and self.segments and tag != "COMMENT":
            self.segments[-1][1][tag] = value
        elif tag == "attitudeState" and self.state is not None:
            self._row(*self.state)
            self.state = None
        elif self.state is not None and value:
            self.state[1][self.name] = value

    def characters(self, data: str) -> None:
        self.text.append(data)

    def _row(self, line: int, values: dict[str, str]) -> None:
        keys = self.segments[-1][1]
        kind = keys.get("ATTITUDE_TYPE", "").strip().upper()
        names = FIELDS.get(kind)
        if names is None:
            raise LogFormatError(
                f"{self.path}, line {line}: ATTITUDE_TYPE = {kind or '(none)'} is not read in the XML form (read: "
                f"{', '.join(FIELDS)})"
            )
        missing = [n for n in ("EPOCH", *names) if n not in values]
        if missing:
            raise LogFormatError(f"{self.path}, line {line}: the attitude state has no {', '.join(missing)}")
        keys["QUATERNION_TYPE"] = "LAST"  # the values below are put in the order Q1 Q2 Q3 QC
        self.segments[-1][2].append((line, [values["EPOCH"], *(values[n] for n in names)]))


def xml_segments(path: str) -> tuple[str, Segments]:
    """``(version, segments)`` of an AEM in XML: each segment ``(its line, its metadata, its rows (line, [epoch,
    numbers ...]))``."""
    parser = expat.ParserCreate()
    reader = _Reader(path, parser)
    parser.StartElementHandler = reader.start
    parser.EndElementHandler = reader.end
    parser.CharacterDataHandler = reader.characters
    try:
        with open(path, "rb") as f:
            parser.ParseFile(f)
    except expat.ExpatError as exc:
        raise LogFormatError(
            f"{path}, line {exc.lineno}: not well-formed XML ({expat.errors.messages[exc.code]})"
        ) from None
    return reader.version, reader.segments
