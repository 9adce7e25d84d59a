"""Where an image file's pixels are, and how many bytes they must take: read before ITK opens anything.

Every image file the package reads is first described here (:func:`image_layout`), in the format
its name says, with ITK's own rules for it (MetaImage's ``metaImage.cxx``, NRRD's ``formatNRRD.c``
and ``parseNrrd.c``, ``nifti1_io.c``, the PNG, JPEG, BMP and TIFF layouts): the files that hold its
pixels, where the pixels start in each, how many bytes they take, and how they are encoded. Two
rules follow from it, checked before SimpleITK reads a byte:

- **confinement**: a header that names other files (MetaImage ``ElementDataFile``, plain, ``LIST``
  or a ``%d`` pattern; NRRD ``data file``, the same three) has every name checked by
  :func:`ffd_notebook._util.file_access.named_file` (inside ``within``, a regular file). What this
  module does not understand exactly it refuses with the reason (a line ITK would read
  differently, a header whose end is not found, a name ITK would take from the working folder),
  so ITK never reads a file the check did not see;
- **whole or nothing** (:func:`check_whole`): raw data is checked against the file's size (no
  read), compressed data (``.nii.gz``, gzip NRRD, compressed MetaImage) is inflated once to its
  end, trailer included, and a PNG, JPEG, BMP or TIFF must reach the end its structure announces.

Text-encoded data (ASCII MetaImage, NRRD ``ascii``/``hex``) is not sized here: ITK refuses it when
values are missing, and :func:`~.files.read_image` says so.
"""

from __future__ import annotations

import os
import re
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._util.file_access import named_file, open_regular
from ..errors import FileFormatError

__all__ = [
    "HEADER_LIMIT",
    "IMAGE_READ_SUFFIXES",
    "DataPart",
    "ImageLayout",
    "check_whole",
    "image_data_files",
    "image_layout",
    "image_suffix",
]

#: A MetaImage or NRRD header must end within its first MiB (a header whose end is not found is refused).
HEADER_LIMIT = 1 << 20
#: the image files the package reads, and the ITK ImageIO that reads each (forced: no guessing by content)
IMAGE_READ_SUFFIXES = {
    ".nii": "NiftiImageIO",
    ".nii.gz": "NiftiImageIO",
    ".hdr": "NiftiImageIO",  # a NIfTI pair: the header, its pixels in the .img beside it
    ".img": "NiftiImageIO",
    ".nrrd": "NrrdImageIO",
    ".nhdr": "NrrdImageIO",
    ".mha": "MetaImageIO",
    ".mhd": "MetaImageIO",
    ".png": "PNGImageIO",
    ".jpg": "JPEGImageIO",
    ".jpeg": "JPEGImageIO",
    ".bmp": "BMPImageIO",
    ".tif": "TIFFImageIO",
    ".tiff": "TIFFImageIO",
}
_MULTI_SUFFIXES = (".nii.gz", ".hdr.gz", ".img.gz")
_MAX_FILES = 65536  # data files a LIST or a pattern may name
_INFLATE_CHUNK = 1 << 20
_EXTRA_INFLATED = 1 << 20  # decompressed bytes accepted past what the header needs (then: not this header's data)


def image_suffix(path: str | os.PathLike[str]) -> str:
    """The extension SimpleITK chooses the format by: ``".nii.gz"`` for ``a.nii.gz``, else the last suffix.

    Parameters
    ----------
    path : str or os.PathLike
        An image file name (the file need not exist).

    Returns
    -------
    str
        The lower-case suffix, with its dot.

    Examples
    --------
    >>> image_suffix("scan.nii.gz"), image_suffix("labels.nrrd"), image_suffix("a.b.mha")
    ('.nii.gz', '.nrrd', '.mha')
    """
    name = Path(path).name.lower()
    for suffix in _MULTI_SUFFIXES:
        if name.endswith(suffix):
            return suffix
    return Path(name).suffix


@dataclass(frozen=True)
class DataPart:
    """One stretch of pixel data: ``length`` bytes once decoded, in ``path`` from byte ``start``.

    ``encoding`` is ``"raw"`` (``length`` bytes as they are), ``"gzip"`` (a gzip or zlib stream
    from ``start`` that must inflate to at least ``length`` bytes and end), or ``"text"`` (numbers
    in text: not sized here). ``from_end``: the data is the file's last ``length`` bytes
    (MetaImage ``HeaderSize = -1``, NRRD ``byte skip: -1``). ``stored``: how many bytes the
    compressed stream takes in the file, when the header says (MetaImage ``CompressedDataSize``).
    ``line`` is the header line that names ``path`` (None for inline data). ``values``: the NumPy
    dtype of the stored values where non-finite ones can be counted (NIfTI floating-point data,
    whose NaN and infinities ITK's NIfTI reader turns into 0), starting ``skip`` bytes into the
    decoded data (a ``.nii.gz`` file's header).
    """

    path: Path
    start: int
    length: int
    encoding: str = "raw"
    from_end: bool = False
    stored: int | None = None
    line: int | None = None
    values: str | None = None
    skip: int = 0


@dataclass(frozen=True)
class ImageLayout:
    """What :func:`image_layout` found: the file, its format, its ITK ImageIO, where its pixels are.

    ``dims`` and ``sizes`` are the header's (``None`` for formats sized by their own structure:
    PNG, JPEG, BMP, TIFF); ``named`` lists the files other than ``path`` the header names.
    """

    path: Path
    format: str
    io: str
    parts: tuple[DataPart, ...]
    sizes: tuple[int, ...] | None = None
    components: int = 1
    pixels: int = 0

    @property
    def named(self) -> list[Path]:
        """The data files other than the image file itself, in the header's order."""
        return [part.path for part in self.parts if part.path != self.path]


# ------------------------------------------------------------------------------------------ entry points
def image_layout(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None) -> ImageLayout:
    """Where the pixels of an image file are (see the module docstring); nothing but its header is read.

    Parameters
    ----------
    path : str or os.PathLike
        An image file of one of :data:`IMAGE_READ_SUFFIXES`.
    within : str or os.PathLike, optional
        The folder every data file the header names must be in (``None``: anywhere).

    Returns
    -------
    ImageLayout
        The format, ITK ImageIO and data parts.

    Raises
    ------
    FileFormatError
        An unknown format, a header this module does not understand exactly, a data file outside
        ``within``, missing or not a regular file; names the file and the line.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.raw").write_bytes(bytes(24))
    >>> _ = (folder / "a.mhd").write_text("NDims = 3\\nDimSize = 4 3 2\\nElementType = MET_UCHAR\\n"
    ...                                    "ElementDataFile = a.raw\\n")
    >>> layout = image_layout(folder / "a.mhd", within=folder)
    >>> layout.format, [(p.path.name, p.start, p.length) for p in layout.parts]
    ('MetaImage', [('a.raw', 0, 24)])
    >>> _ = (folder / "b.mhd").write_text("NDims = 3\\nDimSize = 4 3 2\\nElementType = MET_UCHAR\\n"
    ...                                    "ElementDataFile = LIST\\n../../etc/hostname\\na.raw\\n")
    >>> image_layout(folder / "b.mhd", within=folder)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...b.mhd, line 5: names a data file outside the folder it may read from ...
    """
    target = Path(path)
    suffix = image_suffix(target)
    if suffix not in IMAGE_READ_SUFFIXES:
        raise FileFormatError(target, None, f"unsupported image format {suffix or '(no extension)'!r}; the package "
                              f"reads {', '.join(IMAGE_READ_SUFFIXES)}")  # fmt: skip
    io = IMAGE_READ_SUFFIXES[suffix]
    if io == "MetaImageIO":
        return _metaimage(target, within)
    if io == "NrrdImageIO":
        return _nrrd(target, within)
    if io == "NiftiImageIO":
        return _nifti(target, suffix, within)
    size = os.stat(target).st_size
    if io == "PNGImageIO":
        return ImageLayout(target, "PNG", io, (DataPart(target, 0, _png_end(target, size)),))
    if io == "JPEGImageIO":
        return ImageLayout(target, "JPEG", io, (DataPart(target, 0, _jpeg_end(target, size)),))
    if io == "BMPImageIO":
        return ImageLayout(target, "BMP", io, (DataPart(target, 0, _bmp_end(target, size)),))
    return ImageLayout(target, "TIFF", io, (DataPart(target, 0, _tiff_end(target, size)),))


def image_data_files(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None) -> list[Path]:
    r"""The files other than ``path`` whose bytes reading it would read (MetaImage, NRRD data files), checked.

    ``LIST`` entries and ``%d`` patterns are expanded; each file is checked by the one rule for
    named files (inside ``within``, a regular file). A header this cannot read exactly is refused,
    never passed over.

    Parameters
    ----------
    path : str or os.PathLike
        An image file.
    within : str or os.PathLike, optional
        The folder the data files must be in.

    Returns
    -------
    list of pathlib.Path
        The data files, in the header's order; empty for a format that keeps its pixels inline.

    Raises
    ------
    FileFormatError
        See :func:`image_layout`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> for i in range(2):
    ...     _ = (folder / f"slice{i}.raw").write_bytes(bytes(12))
    >>> _ = (folder / "a.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\n"
    ...                                     "encoding: raw\ndata file: slice%d.raw 0 1 1\n")
    >>> [p.name for p in image_data_files(folder / "a.nhdr")]
    ['slice0.raw', 'slice1.raw']
    """
    return image_layout(path, within=within).named


def check_whole(layout: ImageLayout, *, count_non_finite: bool = False) -> int:
    """Refuse an image whose pixel data ends before its header (or structure) says it does.

    Raw data: one ``os.stat`` per file, and so is compressed data whose length the header gives
    (MetaImage's ``CompressedDataSize``: ITK inflates exactly those bytes and refuses a stream that
    does not give the pixels). Other compressed data (``.nii.gz``, gzip NRRD) is inflated once, in
    1 MiB pieces that are thrown away, to the end of the stream (its CRC and length trailer checked
    by zlib): ITK's NIfTI reader fills a short stream with zeros and NRRD's ignores a cut trailer.

    With ``count_non_finite``, the pixels holding a NaN or infinite value are counted in the
    file's own data where ITK would hide them (NIfTI floating-point data: counted while the
    stream is inflated, or from the mapped file); the count is returned (0 where not counted).

    Raises
    ------
    FileFormatError
        Names the file that ends early and says how many bytes of how many it holds, or that its
        compressed stream ends before its end.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.raw").write_bytes(bytes(20))
    >>> _ = (folder / "a.mhd").write_text("NDims = 3\\nDimSize = 4 3 2\\nElementType = MET_UCHAR\\n"
    ...                                    "ElementDataFile = a.raw\\n")
    >>> check_whole(image_layout(folder / "a.mhd"))
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.mhd, line 4: the pixel data ends early: its data file a.raw has 20 ...
    """
    bad = np.zeros(layout.pixels if count_non_finite and any(p.values for p in layout.parts) else 0, dtype=bool)
    for part in layout.parts:
        if part.encoding == "text":
            continue
        size = os.stat(part.path).st_size
        where = "the file" if part.path == layout.path else f"its data file {part.path.name}"
        if part.length < 0:  # a PNG or JPEG whose structure stops before its end
            raise FileFormatError(layout.path, None, f"the file ends early: its {layout.format} data stops before "
                                  f"its end ({size} bytes)")  # fmt: skip
        if part.encoding == "raw":
            need = part.length if part.from_end else part.start + part.length
            if size < need:
                raise FileFormatError(layout.path, part.line, f"the pixel data ends early: {where} has {size} "
                                      f"bytes of {need}")  # fmt: skip
            if bad.size and part.values:
                _mark_non_finite(bad, np.memmap(part.path, dtype=part.values, mode="r", offset=part.start,
                                                shape=(part.length // np.dtype(part.values).itemsize,)), 0)  # fmt: skip
            continue
        stored = part.stored
        if stored is not None and part.start + stored > size:
            raise FileFormatError(layout.path, part.line, f"the pixel data ends early: {where} has "
                                  f"{max(0, size - part.start)} bytes of the {stored} compressed bytes its header "
                                  "announces")  # fmt: skip
        if stored is not None:  # the header says how long the compressed stream is: the file holds all of it
            continue
        counter = _Counter(bad, part) if bad.size and part.values else None
        _inflate_whole(layout, part, where, size, counter)
    return int(bad.sum())


def _mark_non_finite(bad: np.ndarray, values: np.ndarray, first: int) -> None:
    """Mark in ``bad`` the pixels of the non-finite ``values`` (value ``first + n`` is pixel ``(first + n) % pixels``).

    The values are a pixel's components one after another, as NIfTI stores a vector image (the
    component axis slowest): a value's pixel is its index modulo the number of pixels.
    """
    for start in range(0, len(values), 1 << 22):
        chunk = np.asarray(values[start : start + (1 << 22)])
        where = np.flatnonzero(~np.isfinite(chunk))
        if where.size:
            bad[(where + first + start) % bad.size] = True


class _Counter:
    """Counts the non-finite values of a decoded stream fed piece by piece (whole values only, carried across)."""

    def __init__(self, bad: np.ndarray, part: DataPart) -> None:
        self.bad, self.dtype = bad, np.dtype(part.values)
        self.skip, self.count = part.skip, (part.length - part.skip) // self.dtype.itemsize
        self.seen, self.carry = 0, b""

    def feed(self, data: bytes) -> None:
        if self.skip:
            cut = min(self.skip, len(data))
            data, self.skip = data[cut:], self.skip - cut
        data = self.carry + data
        whole = min(len(data) // self.dtype.itemsize, self.count - self.seen)
        self.carry = data[whole * self.dtype.itemsize :] if whole + self.seen < self.count else b""
        if whole > 0:
            _mark_non_finite(self.bad, np.frombuffer(data, dtype=self.dtype, count=whole), self.seen)
            self.seen += whole


# ------------------------------------------------------------------------------------------ compressed data
def _inflate_whole(layout: ImageLayout, part: DataPart, where: str, end: int, counter: _Counter | None) -> None:
    """Inflate ``part`` (gzip members or a zlib stream) from ``start`` to ``end``; refuse if it stops short."""
    produced = 0
    with open_regular(part.path, max_bytes=1 << 62) as f:
        f.seek(part.start)
        left = end - part.start
        buffer = f.read(min(_INFLATE_CHUNK, left))
        left -= len(buffer)
        gzip = buffer[:2] == b"\x1f\x8b"
        if not gzip and (len(buffer) < 2 or (buffer[0] & 0x0F) != 8 or ((buffer[0] << 8) | buffer[1]) % 31):
            # not compressed after all (ITK's gzip reader reads a plain file as it is): sized as raw data
            if len(buffer) + left < part.length:
                raise FileFormatError(layout.path, part.line, f"the pixel data ends early: {where} holds "
                                      f"{len(buffer) + left} bytes of {part.length}")  # fmt: skip
            return
        inflater = zlib.decompressobj(47)  # gzip or zlib, as ITK's readers accept either
        while True:
            if len(buffer) < 2 and left > 0:
                more = f.read(min(_INFLATE_CHUNK, left))
                left -= len(more)
                buffer += more
            if not buffer:
                break
            if inflater.eof:  # after a stream: another gzip member, or nothing but zero padding
                if gzip and buffer[:2] == b"\x1f\x8b":
                    inflater = zlib.decompressobj(47)
                elif buffer.strip(b"\x00"):
                    raise FileFormatError(layout.path, part.line, f"{where} has data after its compressed pixel "
                                          "stream")  # fmt: skip
                else:
                    buffer = b""
                    continue
            try:
                out = inflater.decompress(buffer, _INFLATE_CHUNK)
            except zlib.error as exc:
                raise FileFormatError(layout.path, part.line, f"the compressed pixel data of {where} is damaged "
                                      f"({exc})") from None  # fmt: skip
            produced += len(out)
            if counter is not None:
                counter.feed(out)
            if produced > part.length + _EXTRA_INFLATED:
                raise FileFormatError(layout.path, part.line, f"the compressed pixel data of {where} inflates to "
                                      f"more than the {part.length} bytes its header needs")  # fmt: skip
            buffer = inflater.unused_data if inflater.eof else inflater.unconsumed_tail
    if not inflater.eof:
        raise FileFormatError(layout.path, part.line, f"the pixel data ends early: the compressed stream of {where} "
                              f"ends before its end ({produced} of {part.length} bytes inflated)")  # fmt: skip
    if produced < part.length:
        raise FileFormatError(layout.path, part.line, f"the pixel data ends early: the compressed stream of {where} "
                              f"holds {produced} bytes of the {part.length} its header needs")  # fmt: skip


# ------------------------------------------------------------------------------------------ text headers
def _head(path: Path, ends: tuple[bytes, ...] = ()) -> bytes:
    """The first :data:`HEADER_LIMIT` bytes of ``path`` (a regular file: checked on open), or fewer: read in
    64 KiB pieces, it stops at the first piece that holds one of ``ends`` (what ends a header)."""
    data = b""
    with open_regular(path, max_bytes=1 << 62) as f:
        while len(data) < HEADER_LIMIT:
            piece = f.read(min(1 << 16, HEADER_LIMIT - len(data)))
            if not piece:
                break
            data += piece
            if any(end in data[max(0, len(data) - len(piece) - 4) :] for end in ends):
                break
    return data


def _atof_int(word: str) -> int:
    """``int(atof(word))`` as C does it: the number at the start of ``word``, 0 if none."""
    match = re.match(r"\s*[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?", word)
    return int(float(match.group(0))) if match else 0


def _product(values: list[int] | tuple[int, ...]) -> int:
    out = 1
    for v in values:
        out *= v
    return out


def _check_name(path: Path, line: int, name: str, kind: str) -> None:
    """Refuse data-file names ITK would not take beside the header, or would read from elsewhere."""
    if name != name.strip() or not name:
        raise FileFormatError(path, line, f"a {kind} data file name with blanks around it or empty: refused")
    if name == "-" or name.startswith("~") or name[1:2] == ":":
        raise FileFormatError(path, line, f"a {kind} data file name ITK would take from the working folder or "
                              f"standard input ({name!r}): refused")  # fmt: skip


_PATTERN = re.compile(r"[^%]*%0?[1-9]?[0-9]?d[^%]*")


def _pattern_names(path: Path, line: int, template: str, numbers: list[int]) -> list[str]:
    if not _PATTERN.fullmatch(template):
        raise FileFormatError(path, line, f"a data file pattern other than one %d (or %0Nd) conversion: "
                              f"{template!r}: refused")  # fmt: skip
    return [template % number for number in numbers]


# MetaImage ------------------------------------------------------------------------------------
_MET_TYPES = {"MET_CHAR": 1, "MET_UCHAR": 1, "MET_SHORT": 2, "MET_USHORT": 2, "MET_INT": 4, "MET_UINT": 4,
              "MET_LONG": 4, "MET_ULONG": 4, "MET_LONG_LONG": 8, "MET_ULONG_LONG": 8, "MET_FLOAT": 4,
              "MET_DOUBLE": 8}  # fmt: skip  # MetaIO's MET_ValueTypeSize
_MET_VECTORS = {"DimSize", "ImagePosition", "ElementOrigin", "SequenceID", "ElementSize", "Position", "Origin",
                "Offset", "CenterOfRotation", "ElementSpacing"}  # fmt: skip  # NDims numbers each
_MET_MATRICES = {"ElementDirection", "TransformMatrix", "Rotation", "Orientation"}  # NDims x NDims numbers
_MET_SCALARS = {"FileFormatVersion", "NDims", "ID", "ParentID", "CompressedDataSize", "HeaderSize", "ElementMin",
                "ElementMax", "ElementNumberOfChannels", "ElementNBits", "ElementToIntensityFunctionSlope",
                "ElementToIntensityFunctionOffset"}  # fmt: skip
#: the fields that say where the pixels are and how many bytes they take: given once or refused
_MET_PLACING = _MET_VECTORS | _MET_MATRICES | _MET_SCALARS | {"ElementType", "BinaryData", "CompressedData"}
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[-+]?(nan|inf|infinity)", re.IGNORECASE)


def _metaimage(path: Path, within: str | os.PathLike[str] | None) -> ImageLayout:
    """A MetaImage header read line by line as MetaIO reads it, refusing every line it could read otherwise."""
    head = _head(path)
    fields: dict[str, tuple[int, str]] = {}
    at, number, data_line = 0, 0, None
    while at < len(head):
        end = head.find(b"\n", at)
        stop = len(head) if end < 0 else end
        raw = head[at:stop].decode("latin-1")
        number += 1
        at = stop + 1
        text = raw[:-1] if raw.endswith("\r") else raw
        if "\r" in text or "\x00" in text:
            raise FileFormatError(path, number, "a carriage return or NUL inside a header line (MetaIO would read "
                                  "the lines differently): refused")  # fmt: skip
        text = text.lstrip(" \t\v\f")
        if not text:
            continue
        cut = min((i for i in (text.find("="), text.find(":")) if i >= 0), default=-1)
        if cut < 0:
            raise FileFormatError(path, number, "a header line without '=' (MetaIO would join it to the next "
                                  "line): refused")  # fmt: skip
        key = text[:cut].rstrip(" \t")
        value = text[cut:].lstrip("=: \t").rstrip()
        loose = re.sub(r"\s", "", key).lower()
        if loose == "elementdatafile" and key != "ElementDataFile":
            raise FileFormatError(path, number, f"{key!r}: a data-file key MetaIO does not read as ElementDataFile: "
                                  "refused")  # fmt: skip
        if not value:
            raise FileFormatError(path, number, f"{key} has no value (MetaIO would take the next line's): refused")
        if key in fields and key in _MET_PLACING:
            raise FileFormatError(path, number, f"{key} given twice (line {fields[key][0]} and {number}): refused")
        fields.setdefault(key, (number, value))
        if key in _MET_VECTORS | _MET_MATRICES | _MET_SCALARS:
            _met_numbers(path, number, key, value, fields)
        if key == "ElementDataFile":
            data_line = number
            break
    if data_line is None:
        why = "in its first MiB" if len(head) >= HEADER_LIMIT else "before the file ends"
        raise FileFormatError(path, None, f"no ElementDataFile line {why}: the header's end is not found")
    dims = int(fields["NDims"][1])
    sizes = [int(v) for v in fields["DimSize"][1].split()] if "DimSize" in fields else None
    if sizes is None:
        raise FileFormatError(path, None, "no DimSize line")
    kind = fields.get("ElementType", (None, ""))[1]
    if kind not in _MET_TYPES:
        raise FileFormatError(path, fields.get("ElementType", (None,))[0], f"ElementType {kind!r}: expected one of "
                              f"{', '.join(_MET_TYPES)}")  # fmt: skip
    channels = int(fields["ElementNumberOfChannels"][1]) if "ElementNumberOfChannels" in fields else 1
    if not 1 <= channels <= 1024:
        raise FileFormatError(path, fields["ElementNumberOfChannels"][0], f"ElementNumberOfChannels {channels}: "
                              "expected 1 to 1024")  # fmt: skip
    element = _MET_TYPES[kind] * channels
    header_size = int(fields["HeaderSize"][1]) if "HeaderSize" in fields else 0
    if header_size < -1:
        raise FileFormatError(path, fields["HeaderSize"][0], f"HeaderSize {header_size}: expected -1 or more")
    binary = fields.get("BinaryData", (0, "True"))[1][:1] in "Tt1"
    compressed = binary and fields.get("CompressedData", (0, "False"))[1][:1] in "Tt1"
    stored = int(fields["CompressedDataSize"][1]) if compressed and "CompressedDataSize" in fields else None
    if compressed and header_size == -1:
        raise FileFormatError(path, fields["HeaderSize"][0], "HeaderSize = -1 with compressed data: refused")
    encoding = "text" if not binary else ("gzip" if compressed else "raw")
    total = _product(sizes) * element
    source = fields["ElementDataFile"][1]
    words = source.split()

    def part(file: Path, length: int, start: int, line: int | None) -> DataPart:
        if encoding == "gzip":
            return DataPart(file, max(start, 0), length, "gzip", stored=stored if stored else None, line=line)
        return DataPart(file, max(start, 0), length, encoding, from_end=header_size == -1, line=line)

    if source in ("LOCAL", "Local", "local"):
        start = header_size if header_size > 0 else at
        parts: tuple[DataPart, ...] = (part(path, total, start, None),)
    elif source[:4] == "LIST":
        if words[0] != "LIST" or len(words) > 2 or compressed:
            raise FileFormatError(path, data_line, "a LIST data source other than 'LIST' or 'LIST <n>D' (or a "
                                  "compressed list): refused")  # fmt: skip
        file_dims = _atof_int(words[1].strip("[]")) if len(words) > 1 else 0  # "[2D]": MetaIO reads 0 (the default)
        if len(words) > 1 and words[1].startswith("["):
            file_dims = 0
        if not 0 < file_dims < dims:
            file_dims = dims - 1
        count = _product(sizes[file_dims:])
        if count > _MAX_FILES:
            raise FileFormatError(path, data_line, f"a LIST of {count} data files, more than {_MAX_FILES}: refused")
        names = head[at:].decode("latin-1").split("\n")
        if len(names) < count + 1:  # MetaIO drops a last name that no line end follows
            raise FileFormatError(path, data_line, f"its LIST names fewer than the {count} data files DimSize needs")
        per_file = total // count
        parts = tuple(
            part(named_file(path, _met_list_name(path, data_line + 1 + i, names[i]), within=within,
                            line=data_line + 1 + i, max_bytes=1 << 62),
                 per_file, header_size, data_line + 1 + i)
            for i in range(count)
        )  # fmt: skip
    elif "%" in source:
        if len(words) != 4 or compressed or not all(re.fullmatch(r"-?\d+", w) for w in words[1:]):
            raise FileFormatError(path, data_line, "a data file pattern other than '<name%d> <first> <last> <step>' "
                                  "(or a compressed one): refused")  # fmt: skip
        first, last, step = (int(w) for w in words[1:])
        count = 1 + (last - first) // step if step > 0 and last >= first else 0
        if count != sizes[-1] or (step > 0 and (last - first) % step) or count > _MAX_FILES:
            raise FileFormatError(path, data_line, f"a data file pattern for {count} files where DimSize needs "
                                  f"{sizes[-1]}: refused")  # fmt: skip
        names = _pattern_names(path, data_line, words[0], list(range(first, last + 1, step)))
        for name in names:
            _check_name(path, data_line, name, "MetaImage")
        per_file = total // count
        parts = tuple(part(named_file(path, name, within=within, line=data_line, max_bytes=1 << 62), per_file,
                           header_size, data_line) for name in names)  # fmt: skip
    else:
        _check_name(path, data_line, source, "MetaImage")
        parts = (part(named_file(path, source, within=within, line=data_line, max_bytes=1 << 62), total,
                      header_size, data_line),)  # fmt: skip
    return ImageLayout(path, "MetaImage", "MetaImageIO", parts, tuple(sizes), channels)


def _met_list_name(path: Path, line: int, raw: str) -> str:
    name = raw.rstrip()  # MetaIO strips trailing blanks and unprintable characters from a LIST line
    _check_name(path, line, name, "MetaImage LIST")
    return name


def _met_numbers(path: Path, line: int, key: str, value: str, fields: dict[str, tuple[int, str]]) -> None:
    """Refuse a numeric MetaImage field whose numbers MetaIO would read otherwise (too few: from the next line)."""
    tokens = value.split()
    if key in _MET_SCALARS:
        wanted = 1
    else:
        if "NDims" not in fields:
            raise FileFormatError(path, line, f"{key} before NDims: refused")
        dims = int(fields["NDims"][1])
        wanted = dims * dims if key in _MET_MATRICES else dims
    if len(tokens) != wanted or not all(_NUMBER.fullmatch(t) for t in tokens):
        raise FileFormatError(path, line, f"{key} must be {wanted} number(s), got {value[:80]!r}")
    if key == "NDims" and not (re.fullmatch(r"[0-9]{1,2}", value) and 1 <= int(value) <= 3):
        raise FileFormatError(path, line, f"NDims must be a whole number from 1 to 3, got {value!r}")
    if key == "DimSize" and not all(re.fullmatch(r"[0-9]{1,12}", t) and int(t) > 0 for t in tokens):
        raise FileFormatError(path, line, f"DimSize must be {wanted} positive whole numbers, got {value[:80]!r}")
    if key in ("HeaderSize", "ElementNumberOfChannels", "CompressedDataSize") and not re.fullmatch(r"-?\d{1,15}",
                                                                                                   value):  # fmt: skip
        raise FileFormatError(path, line, f"{key} must be a whole number, got {value[:80]!r}")


# NRRD -------------------------------------------------------------------------------------------
_NRRD_TYPES = {
    1: ("signed char", "int8", "int8_t", "uchar", "unsigned char", "uint8", "uint8_t"),
    2: ("short", "short int", "signed short", "signed short int", "int16", "int16_t", "ushort", "unsigned short",
        "unsigned short int", "uint16", "uint16_t"),
    4: ("int", "signed int", "int32", "int32_t", "uint", "unsigned int", "uint32", "uint32_t", "float"),
    8: ("longlong", "long long", "long long int", "signed long long", "signed long long int", "int64", "int64_t",
        "ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t", "double"),
}  # fmt: skip  # teem's nrrdType names
_NRRD_TYPE_BYTES = {name: size for size, names in _NRRD_TYPES.items() for name in names}
_NRRD_ENCODINGS = {"raw": "raw", "gzip": "gzip", "gz": "gzip", "ascii": "text", "text": "text", "txt": "text",
                   "hex": "text"}  # fmt: skip
_NRRD_FIELDS = {"type", "dimension", "sizes", "encoding", "line skip", "lineskip", "byte skip", "byteskip",
                "data file", "datafile"}  # fmt: skip  # the fields whose values place the data
_NRRD_LOOSE = {re.sub(r"\s", "", field) for field in _NRRD_FIELDS}  # the same, blanks dropped
_BLANK_LINES = (b"\n\n", b"\r\r", b"\n\r")  # two line ends in a row (teem's "\r\n" is one): a blank line


def _nrrd_lines(head: bytes) -> list[tuple[int, str, int]]:
    """``(number, text, end)`` of each line as teem's ``airOneLine`` splits them (``\\n``, ``\\r\\n`` or ``\\r``),
    ``end`` the offset after its terminator; a last line without one comes with ``end = -1``."""
    out, at, number = [], 0, 0
    for match in re.finditer(rb"\r\n|\r|\n", head):
        number += 1
        out.append((number, head[at : match.start()].decode("latin-1"), match.end()))
        at = match.end()
    if at < len(head):
        out.append((number + 1, head[at:].decode("latin-1"), -1))
    return out


def _nrrd(path: Path, within: str | os.PathLike[str] | None) -> ImageLayout:
    """A NRRD header read as teem reads it, refusing every line it could read otherwise."""
    head = _head(path, _BLANK_LINES)
    blank = [i for i in (head.find(end) for end in _BLANK_LINES) if i >= 0]
    lines = _nrrd_lines(head[: min(blank) + 3] if blank else head)  # the header only (attached data follows)
    if not lines or not re.fullmatch(r"NRRD000[1-5]", lines[0][1]):
        raise FileFormatError(path, 1, "not a NRRD header (its first line must be NRRD0001 to NRRD0005)")
    fields: dict[str, tuple[int, str]] = {}
    data_start, data_line, list_names = None, None, None
    index = 1
    while index < len(lines):
        number, text, end = lines[index]
        index += 1
        if end < 0:
            raise FileFormatError(path, number, "the header's last line has no line end (teem drops it): refused"
                                  if len(head) < HEADER_LIMIT else "no blank line ends the header in its first MiB: "
                                  "the header's end is not found")  # fmt: skip
        if not text:
            data_start = end
            break
        if "\x00" in text:
            raise FileFormatError(path, number, "a NUL byte in a header line: refused")
        if text.startswith("#"):
            continue
        key, sep, value = text.partition(": ")
        loose = re.sub(r"\s", "", text.partition(":")[0]).lower()
        if loose in _NRRD_LOOSE and (not sep or key.lower() not in _NRRD_FIELDS):
            raise FileFormatError(path, number, f"{text.partition(':')[0]!r}: a field teem would read otherwise "
                                  "(spelling, blanks or a separator other than ': '): refused")  # fmt: skip
        if not sep:
            continue  # "key:=value" pairs and what teem refuses itself
        key = key.lower().replace("lineskip", "line skip").replace("byteskip", "byte skip")
        key = "data file" if key == "datafile" else key
        if key not in _NRRD_FIELDS:
            continue
        if key in fields:
            raise FileFormatError(path, number, f"{key!r} given twice (lines {fields[key][0]} and {number}): refused")
        value = value.lstrip(" \t")
        fields[key] = (number, value)
        if key == "data file":
            data_line = number
            if value.split()[:1] in (["LIST"], ["SKIPLIST"]):  # the names follow, one a line, to a blank line
                list_names = []
                while index < len(lines) and lines[index][1]:
                    if lines[index][2] < 0:
                        raise FileFormatError(path, lines[index][0], "the header's last line has no line end: "
                                              "refused")  # fmt: skip
                    list_names.append(lines[index][:2])
                    index += 1
                if any(text.strip() for _, text, _ in lines[index:]):  # ITK 5.4's teem reads on to the end
                    raise FileFormatError(path, lines[index][0], "lines after the blank line that ends the LIST "
                                          "(teem versions read them differently): refused")  # fmt: skip
                if index < len(lines):
                    data_start = lines[index][2]
                break
    if data_start is None and data_line is None:
        why = "in its first MiB" if len(head) >= HEADER_LIMIT else "before the file ends"
        raise FileFormatError(path, None, f"no blank line ends the header {why} and no data file is named: the "
                              "header's end is not found")  # fmt: skip
    for key in ("type", "dimension", "sizes", "encoding"):
        if key not in fields:
            raise FileFormatError(path, None, f"no {key!r} field")
    line, text = fields["dimension"]
    if not re.fullmatch(r"[0-9]{1,2}", text) or not 1 <= int(text) <= 4:
        raise FileFormatError(path, line, f"dimension must be a whole number from 1 to 4, got {text!r}")
    dims = int(text)
    line, text = fields["sizes"]
    sizes = text.split()
    if len(sizes) != dims or not all(re.fullmatch(r"[0-9]{1,12}", v) and int(v) > 0 for v in sizes):
        raise FileFormatError(path, line, f"sizes must be {dims} positive whole numbers, got {text[:80]!r}")
    counts = [int(v) for v in sizes]
    line, kind = fields["type"]
    if kind.lower().strip() not in _NRRD_TYPE_BYTES:
        raise FileFormatError(path, line, f"type {kind!r}: not a type the package reads")
    line, name = fields["encoding"]
    encoding = _NRRD_ENCODINGS.get(name.lower().strip())
    if encoding is None:
        raise FileFormatError(path, line, f"encoding {name!r}: expected raw, gzip, ascii or hex")
    skips = {}
    for key in ("line skip", "byte skip"):
        where, text = fields.get(key, (0, "0"))
        if not re.fullmatch(r"-?[0-9]{1,12}", text.strip()) or int(text) < (-1 if key == "byte skip" else 0):
            raise FileFormatError(path, where, f"{key} must be a whole number, got {text!r}")
        skips[key] = int(text)
    if skips["line skip"] and encoding != "text":
        raise FileFormatError(path, fields["line skip"][0], "line skip with binary data: not read by the package")
    if skips["byte skip"] == -1 and encoding != "raw":
        raise FileFormatError(path, fields["byte skip"][0], "byte skip: -1 is for raw data only")
    total = _product(counts) * _NRRD_TYPE_BYTES[kind.lower().strip()]

    def part(file: Path, length: int, start: int, line: int | None) -> DataPart:
        skip = skips["byte skip"]
        return DataPart(file, start + max(skip, 0), length, encoding, from_end=skip == -1, line=line)

    if data_line is None:
        assert data_start is not None
        parts: tuple[DataPart, ...] = (part(path, total, data_start, None),)
        return ImageLayout(path, "NRRD", "NrrdImageIO", parts, tuple(counts))
    value = fields["data file"][1]
    words = value.split()
    if list_names is not None:
        if words[0] != "LIST" or len(words) > 2 or (len(words) == 2 and not re.fullmatch(r"[0-9]{1,2}", words[1])):
            raise FileFormatError(path, data_line, "a LIST data source other than 'LIST' or 'LIST <n>': refused")
        file_dims = int(words[1]) if len(words) == 2 else dims - 1
        names = [(n, _nrrd_name(path, n, text)) for n, text in list_names]
    elif "%" in value:
        if not 4 <= len(words) <= 5 or not all(re.fullmatch(r"-?\d{1,9}", w) for w in words[1:]):
            raise FileFormatError(path, data_line, "a data file pattern other than '<name%d> <min> <max> <step> "
                                  "[<dim>]': refused")  # fmt: skip
        low, high, step = (int(w) for w in words[1:4])
        file_dims = int(words[4]) if len(words) == 5 else dims - 1
        if step == 0 or (high - low) * step < 0:
            raise FileFormatError(path, data_line, f"a data file pattern from {low} to {high} by {step}: refused")
        numbers = list(range(low, high + (1 if step > 0 else -1), step)[: _MAX_FILES + 1])
        names = [(data_line, _nrrd_name(path, data_line, n)) for n in _pattern_names(path, data_line, words[0],
                                                                                       numbers)]  # fmt: skip
    else:
        names = [(data_line, _nrrd_name(path, data_line, value))]
        file_dims = dims
    if not 1 <= file_dims <= dims:
        raise FileFormatError(path, data_line, f"a data file dimension {file_dims} outside 1 to {dims}: refused")
    expected = _product(counts[file_dims:])
    if len(names) != expected:
        raise FileFormatError(path, data_line, f"{len(names)} data files where the sizes need {expected}: refused")
    per_file = total // len(names)
    parts = tuple(part(named_file(path, name, within=within, line=line, max_bytes=1 << 62), per_file, 0, line)
                  for line, name in names)  # fmt: skip
    return ImageLayout(path, "NRRD", "NrrdImageIO", parts, tuple(counts))


def _nrrd_name(path: Path, line: int, name: str) -> str:
    _check_name(path, line, name, "NRRD")
    return name


# NIfTI ------------------------------------------------------------------------------------------
def _nifti(path: Path, suffix: str, within: str | os.PathLike[str] | None) -> ImageLayout:
    """A NIfTI-1 or NIfTI-2 image, one file or a ``.hdr``/``.img`` pair: its pixels sized by its header (nibabel).

    A pair's pixels are in the ``.img`` beside the ``.hdr`` (the name ``nifti1_io`` takes, in the case of the
    name given): a file the header names, checked by the one rule (inside ``within``). A pair whose data could
    be read from two files (``.img`` and ``.img.gz``) is refused, as is an Analyze 7.5 header (no NIfTI magic:
    its orientation is not in the file, ITK would guess it).
    """
    import gzip

    import nibabel

    pair = suffix in (".hdr", ".img")
    header_path = path
    if pair:
        upper = path.suffix.isupper()
        header_path = path.with_suffix(".HDR" if upper else ".hdr")
        if header_path != path:
            header_path = named_file(path, header_path.name, within=within, what="header (the .hdr of a NIfTI pair)")
    with open_regular(header_path, max_bytes=1 << 62) as f:
        compressed = f.read(2) == b"\x1f\x8b"
        f.seek(0)
        try:
            raw = gzip.GzipFile(fileobj=f).read(544) if compressed else f.read(544)
        except (OSError, EOFError, zlib.error) as exc:
            raise FileFormatError(header_path, None, f"not a NIfTI file: its compressed header cannot be read "
                                  f"({exc})") from None  # fmt: skip
    if len(raw) < 348:
        raise FileFormatError(header_path, None, f"not a NIfTI file: {len(raw)} bytes, shorter than a NIfTI header")
    sizes = {struct.unpack("<i", raw[:4])[0], struct.unpack(">i", raw[:4])[0]}
    header_class = nibabel.Nifti2Header if 540 in sizes else nibabel.Nifti1Header
    try:
        size = 540 if header_class is nibabel.Nifti2Header else 348
        header = header_class(binaryblock=raw[:size], check=False)  # the header only (extensions are not read)
        magic = bytes(header["magic"]).rstrip(b"\x00")
        shape = header.get_data_shape()
        dtype = header.get_data_dtype()
        offset = int(header.get_data_offset())
    except Exception as exc:  # nibabel's errors on a damaged header are of many kinds
        raise FileFormatError(header_path, None, f"not a NIfTI header nibabel understands ({exc})") from None
    if pair:
        if magic not in (b"ni1", b"ni2"):
            what = "an Analyze 7.5 header (no NIfTI magic): its orientation is not in the file, ITK would guess it"
            raise FileFormatError(header_path, None, what if not magic else f"NIfTI magic {magic!r} in a .hdr file "
                                  "(a pair's header says ni1 or ni2)")  # fmt: skip
        if compressed:
            raise FileFormatError(header_path, None, "a compressed .hdr: the pair is read uncompressed only")
        data_name = header_path.with_suffix(".IMG" if header_path.suffix.isupper() else ".img").name
        if (header_path.parent / (data_name + ".gz")).exists() and (header_path.parent / data_name).exists():
            raise FileFormatError(header_path, None, f"both {data_name} and {data_name}.gz are beside it: which "
                                  "holds its pixels is not certain")  # fmt: skip
        data_path = named_file(header_path, data_name, within=within, what="data file (the .img of a NIfTI pair)")
        values = _product([int(n) for n in shape])
        length = values * dtype.itemsize
        floats = dtype.str if dtype.kind == "f" else None
        part = DataPart(data_path, max(offset, 0), length, values=floats)
        components = int(shape[4]) if len(shape) >= 5 else 1
        layout_path = path
        return ImageLayout(layout_path, "NIfTI pair", "NiftiImageIO", (part,), tuple(int(n) for n in shape),
                           pixels=values // max(components, 1))  # fmt: skip
    if magic not in (b"n+1", b"n+2"):
        raise FileFormatError(path, None, f"NIfTI magic {magic!r} in a single-file NIfTI (it says n+1 or n+2); a "
                              "header whose pixels are in another file is a .hdr/.img pair")  # fmt: skip
    offset = max(offset, 352 if magic == b"n+1" else 544)
    values = _product([int(n) for n in shape])
    length = values * dtype.itemsize
    floats = dtype.str if dtype.kind == "f" else None
    if compressed:
        part = DataPart(path, 0, offset + length, "gzip", values=floats, skip=offset)
    else:
        part = DataPart(path, offset, length, values=floats)
    components = int(shape[4]) if len(shape) >= 5 else 1
    pixels = values // max(components, 1)
    return ImageLayout(path, "NIfTI", "NiftiImageIO", (part,), tuple(int(n) for n in shape), pixels=pixels)


# PNG, JPEG, BMP, TIFF: where the file's own structure says it ends -----------------------------------
def _read_at(path: Path, start: int, count: int) -> bytes:
    with open_regular(path, max_bytes=1 << 62) as f:
        f.seek(start)
        return f.read(count)


def _png_end(path: Path, size: int) -> int:
    """The end of a PNG's IEND chunk, walking the chunk lengths (the size the file must have)."""
    with open_regular(path, max_bytes=1 << 62) as f:
        if f.read(8) != b"\x89PNG\r\n\x1a\n":
            raise FileFormatError(path, None, "not a PNG file (no PNG signature)")
        at = 8
        for _ in range(1 << 20):
            f.seek(at)
            head = f.read(8)
            if len(head) < 8:
                return -1  # the chunks stop before IEND
            length, kind = struct.unpack(">I4s", head)
            at += 12 + length
            if kind == b"IEND":
                return at if at <= size else -1
    raise FileFormatError(path, None, "a PNG with more than a million chunks: refused")


def _jpeg_end(path: Path, size: int) -> int:
    """A JPEG must end with its end-of-image marker (which cannot occur inside its compressed data)."""
    if _read_at(path, 0, 2) != b"\xff\xd8":
        raise FileFormatError(path, None, "not a JPEG file (no start-of-image marker)")
    return size if _read_at(path, max(size - 2, 0), 2) == b"\xff\xd9" else -1


def _bmp_end(path: Path, size: int) -> int:
    """The end of a BMP's pixel array, from its headers."""
    head = _read_at(path, 0, 54)
    if len(head) < 26 or head[:2] != b"BM":
        raise FileFormatError(path, None, "not a BMP file (no BM signature)")
    offset, header_size = struct.unpack("<I", head[10:14])[0], struct.unpack("<I", head[14:18])[0]
    if header_size == 12:
        width, height, bits = struct.unpack("<HH", head[18:22]) + (struct.unpack("<H", head[24:26])[0],)
        compression, stored = 0, 0
    elif len(head) >= 38:
        width, height = struct.unpack("<ii", head[18:26])
        bits, compression, stored = struct.unpack("<H", head[28:30])[0], *struct.unpack("<II", head[30:38])
    else:
        return size + 1
    if compression in (1, 2):  # run-length encoded: its stored size
        return offset + stored
    return offset + ((bits * abs(width) + 31) // 32) * 4 * abs(height)


_TIFF_TYPE_BYTES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 13: 4}


def _tiff_end(path: Path, size: int) -> int:
    """The furthest byte a classic TIFF's directories, tag values, strips and tiles reach."""
    with open_regular(path, max_bytes=1 << 62) as f:
        head = f.read(8)
        if head[:4] not in (b"II*\x00", b"MM\x00*"):
            raise FileFormatError(path, None, "not a classic TIFF file (BigTIFF is not read)")
        order = "<" if head[:2] == b"II" else ">"
        need, seen = 8, set[int]()
        ifd = struct.unpack(order + "I", head[4:8])[0]
        while ifd and ifd not in seen and len(seen) < 65536:
            seen.add(ifd)
            f.seek(ifd)
            raw = f.read(2)
            if len(raw) < 2:
                return max(need, ifd + 2, size + 1)
            count = struct.unpack(order + "H", raw)[0]
            entries = f.read(12 * count + 4)
            need = max(need, ifd + 2 + 12 * count + 4)
            if len(entries) < 12 * count + 4:
                return max(need, size + 1)
            arrays: dict[int, list[int]] = {}
            for i in range(count):
                tag, kind, n = struct.unpack(order + "HHI", entries[12 * i : 12 * i + 8])
                width = _TIFF_TYPE_BYTES.get(kind, 1) * n
                if width > 4:
                    start = struct.unpack(order + "I", entries[12 * i + 8 : 12 * i + 12])[0]
                    need = max(need, start + width)
                if tag in (273, 279, 324, 325) and kind in (3, 4) and n <= 1 << 20:
                    step = 2 if kind == 3 else 4
                    if width > 4:
                        data = _read_at(path, start, width) if start + width <= size else b""
                    else:
                        data = entries[12 * i + 8 : 12 * i + 8 + width]
                    if len(data) == width:
                        arrays[tag] = list(struct.unpack(order + ("H" if step == 2 else "I") * n, data))
            for offsets, counts in ((273, 279), (324, 325)):
                for start, length in zip(arrays.get(offsets, []), arrays.get(counts, []), strict=False):
                    need = max(need, start + length)
            ifd = struct.unpack(order + "I", entries[12 * count : 12 * count + 4])[0]
            if ifd:
                need = max(need, ifd + 2)
    return need
