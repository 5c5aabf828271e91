"""HDF5 files written by latdyn itself (Python and NumPy; neither h5py nor libhdf5 is loaded).

A run's HDF5 files (``state.h5``, the ParaView parts' VTKHDF files) hold what h5py would write with
the options latdyn gives it — the same objects, hard links and their names' character sets, types
(class, size, byte order, string padding and character set), dataspaces, chunk shapes, fill values,
attributes and values; no times tracked — though not the same bytes (tests/test_hdf5_writer.py
compares them object by object with h5py's). Reading them back (``Result``, resuming, the tests)
goes through h5py.

*The format* (the HDF5 File Format Specification, version 2.0/3.0; only what these files need, in
the versions HDF5 1.8 and later read, so ParaView's VTK (HDF5 1.14) and h5py (2.0) both do):

- superblock version 0 at offset 0 (96 bytes; offsets and lengths of 8 bytes, group leaf K 4,
  internal K 16, chunk B-tree K 32), its root group symbol-table entry naming the root group's
  object header, no cached scratch-pad;
- version 1 object headers (no checksums); a group is a "new-style" compact group: a Link Info
  message (no fractal heap, no name index), a Group Info message and one Link message a link (hard
  links; the name's character set ASCII, or UTF-8 where it is not ASCII); a dataset has Dataspace
  (version 1; scalar is rank 0), Datatype (version 1: little-endian two's-complement integers,
  IEEE floats, fixed-length strings, variable-length UTF-8 strings), Fill Value (version 2: the
  default, or a value the caller gives; allocation late for contiguous data, incremental for
  chunks; written if set) and Layout (version 3: contiguous, or chunked with a version 1 B-tree
  of chunks, K = 32, several levels where the chunks need them) messages;
- attributes as Attribute messages (version 1, or version 3 for a UTF-8 name); variable-length
  strings' bytes in a global heap collection of their own (at least 4096 bytes, as HDF5 reads one).
  Large attribute messages live in a continuation chunk of the object header written once (the
  labels of a state history are not written again at every flush); a message is at most 65535
  bytes (:class:`TooLarge`; 4092 variable-length strings in one attribute).

*How a file grows, and why a crash leaves it readable* (:meth:`File.flush`): a chunked dataset's
chunks are allocated at the end of the file when the first of their rows arrives and written in
place as rows arrive (a whole chunk is allocated at once: its unwritten rows hold the fill value).
At a flush, the object headers (which hold the datasets' extents and the groups' links) are written
anew into one of two metadata areas, the one the superblock does not point at (a new area at the end
of the file when it is too small), and B-tree nodes, heaps and attribute chunks that changed are
written at the end of the file; the superblock at offset 0, rewritten last (96 bytes, one write),
then points at them. Nothing the superblock points at is overwritten before the superblock no longer
points at it, so a process killed at any moment leaves the file as its last flush left it (rows
appended since are beyond its datasets' extents), and a reader that opens the file after a flush
reads that flush's file while the next flush is written. The file's size grows only with its data,
its B-tree nodes and the two metadata areas.
"""
from __future__ import annotations

import os
import struct
import sys
from pathlib import Path

import numpy as np

__all__ = ["File", "Group", "Dataset", "TooLarge", "VLEN_STR", "fits"]

UNDEFINED = 0xFFFFFFFFFFFFFFFF  # an undefined address; an unlimited dimension
SIGNATURE = b"\x89HDF\r\n\x1a\n"
SUPERBLOCK_SIZE = 96
CHUNK_BTREE_K = 32  # the chunk B-tree's K (superblock version 0 cannot name another): 2K entries a node
GLOBAL_HEAP_MIN = 4096  # HDF5 reads a global heap collection's first 4096 bytes
MESSAGE_MAX = 0xFFFF
_PWRITE = hasattr(os, "pwrite")
_PWRITEV = hasattr(os, "pwritev")
_BINARY = getattr(os, "O_BINARY", 0)  # Windows: no newline translation

#: object header message types (format specification, IV.A.2)
DATASPACE, LINK_INFO, DATATYPE, FILL_VALUE, LINK, LAYOUT, GROUP_INFO, ATTRIBUTE, CONTINUATION, ATTRIBUTE_INFO, \
    REFERENCE_COUNT = 0x01, 0x02, 0x03, 0x05, 0x06, 0x08, 0x0A, 0x0C, 0x10, 0x15, 0x16

#: a variable-length UTF-8 string (the type h5py gives a str or a list of str)
VLEN_STR = "vlen-utf8"


class TooLarge(ValueError):
    """An object header message longer than a version 1 header holds (65535 bytes)."""


def _pad8(data: bytes) -> bytes:
    return data + b"\0" * (-len(data) % 8)


# ----------------------------------------------------------------------------- types and spaces
def _datatype(kind) -> bytes:
    """The Datatype message (version 1) of a NumPy dtype, ``("S", n)`` (fixed-length ASCII, null
    padded, as h5py stores ``np.bytes_``) or :data:`VLEN_STR`."""
    if kind == VLEN_STR:  # variable-length string (type 1), null-terminated, UTF-8; base: unsigned char
        base = _datatype(np.dtype(np.uint8))
        return struct.pack("<BBBBI", 0x19, 0x01, 0x01, 0, 16) + base
    if isinstance(kind, tuple) and kind[0] == "S":
        return struct.pack("<BBBBI", 0x13, 0x01, 0, 0, kind[1])  # null pad, ASCII
    dtype = np.dtype(kind)
    if dtype.byteorder == ">":
        raise ValueError(f"big-endian {dtype} is not written")
    if dtype.kind in "iu":
        flags = 0x08 if dtype.kind == "i" else 0
        return struct.pack("<BBBBIHH", 0x10, flags, 0, 0, dtype.itemsize, 0, 8 * dtype.itemsize)
    if dtype.kind == "f" and dtype.itemsize in (4, 8):
        if dtype.itemsize == 8:
            return struct.pack("<BBBBIHHBBBBI", 0x11, 0x20, 63, 0, 8, 0, 64, 52, 11, 0, 52, 1023)
        return struct.pack("<BBBBIHHBBBBI", 0x11, 0x20, 31, 0, 4, 0, 32, 23, 8, 0, 23, 127)
    raise ValueError(f"a dataset or attribute of {dtype} is not written")


def _dataspace(shape: tuple | None, maxshape: tuple | None = None) -> bytes:
    """The Dataspace message (version 2): ``shape`` None or () is scalar; ``maxshape`` None: the shape
    (not stored), a None dimension unlimited."""
    shape = () if shape is None else tuple(int(n) for n in shape)
    dims = b"".join(struct.pack("<Q", n) for n in shape)
    flags = 0
    if maxshape is not None and tuple(maxshape) != shape:
        flags = 1
        dims += b"".join(struct.pack("<Q", UNDEFINED if n is None else int(n)) for n in maxshape)
    return struct.pack("<BBBB", 2, len(shape), flags, 1 if shape else 0) + dims


def _message(kind: int, data: bytes, version: int = 1) -> bytes:
    """One object header message: version 1 (type, size, flags; data padded to 8 bytes) or 2 (type of
    one byte, size, flags; data unpadded)."""
    if version == 1:
        data = _pad8(data)
    if len(data) > MESSAGE_MAX:
        raise TooLarge(f"an HDF5 object header message of {len(data)} bytes (at most {MESSAGE_MAX})")
    if version == 1:
        return struct.pack("<HHB3x", kind, len(data), 0) + data
    return struct.pack("<BHB", kind, len(data), 0) + data


M32 = 0xFFFFFFFF


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle`` of ``data``: the checksum of version 2 object headers (and
    of HDF5's other checksummed metadata)."""
    n = len(data)
    a = b = c = (0xDEADBEEF + n + initval) & M32
    words = np.frombuffer(_pad_to(data, 12), dtype="<u4").tolist()
    if n == 0:
        return c
    blocks = (n - 1) // 12  # the last block, whole or not, goes to the final mix
    for i in range(0, 3 * blocks, 3):
        a, b, c = (a + words[i]) & M32, (b + words[i + 1]) & M32, (c + words[i + 2]) & M32
        a = (a - c) & M32; a ^= ((c << 4) | (c >> 28)) & M32; c = (c + b) & M32
        b = (b - a) & M32; b ^= ((a << 6) | (a >> 26)) & M32; a = (a + c) & M32
        c = (c - b) & M32; c ^= ((b << 8) | (b >> 24)) & M32; b = (b + a) & M32
        a = (a - c) & M32; a ^= ((c << 16) | (c >> 16)) & M32; c = (c + b) & M32
        b = (b - a) & M32; b ^= ((a << 19) | (a >> 13)) & M32; a = (a + c) & M32
        c = (c - b) & M32; c ^= ((b << 4) | (b >> 28)) & M32; b = (b + a) & M32
    i = 3 * blocks
    a, b, c = (a + words[i]) & M32, (b + words[i + 1]) & M32, (c + words[i + 2]) & M32
    c ^= b; c = (c - (((b << 14) | (b >> 18)) & M32)) & M32
    a ^= c; a = (a - (((c << 11) | (c >> 21)) & M32)) & M32
    b ^= a; b = (b - (((a << 25) | (a >> 7)) & M32)) & M32
    c ^= b; c = (c - (((b << 16) | (b >> 16)) & M32)) & M32
    a ^= c; a = (a - (((c << 4) | (c >> 28)) & M32)) & M32
    b ^= a; b = (b - (((a << 14) | (a >> 18)) & M32)) & M32
    c ^= b; c = (c - (((b << 24) | (b >> 8)) & M32)) & M32
    return c


def _pad_to(data: bytes, k: int) -> bytes:
    return bytes(data) + bytes(-len(data) % k)


def checksum(data: bytes) -> int:
    """:func:`lookup3` of ``data``, in C (``latdyn_lookup3`` of latdyn/assembly/csrc/checksum.c) where the
    process has loaded the runtime's native library (a run's compiled steps), else in Python: the same
    value (tests/test_hdf5_writer.py). Nothing is compiled or loaded here."""
    library = sys.modules.get("latdyn.assembly.library")
    native = library.loaded_library() if library is not None else None
    if native is None:
        return lookup3(data)
    data = bytes(data)
    return native.latdyn_lookup3(data, len(data), 0)


def _checksummed(data: bytes) -> bytes:
    return data + struct.pack("<I", checksum(data))


# ----------------------------------------------------------------------------- attributes
class _Attribute:
    """An attribute's type, space and value bytes (strings of a variable-length value in ``strings``)."""

    def __init__(self, name: str, value):
        self.name, self.strings = name, None
        if isinstance(value, str):
            self.kind, self.shape, self.strings = VLEN_STR, (), [value]
        elif isinstance(value, (list, tuple)) and value and all(type(v) is str for v in value):
            self.kind, self.shape, self.strings = VLEN_STR, (len(value),), list(value)
        elif isinstance(value, np.bytes_):
            self.kind, self.shape, self.data = ("S", max(1, len(value))), (), bytes(value) or b"\0"
        else:
            array = np.asarray(value)
            if isinstance(value, (list, tuple)) and not len(value):
                array = np.zeros(0)  # h5py: an empty list is float64 (0,)
            if array.dtype.kind not in "iuf":
                raise ValueError(f"attribute {name!r}: a {array.dtype} value is not written")
            array = np.asarray(array, dtype=array.dtype.newbyteorder("<"))  # 0-d stays 0-d
            self.kind, self.shape, self.data = array.dtype, array.shape, array.tobytes()

    def message(self, heap_address: int = 0, indices=(), encoded=()) -> tuple[int, bytes]:
        """The Attribute message (version 1; version 3 for a non-ASCII name); a variable-length
        value's strings (``encoded``, UTF-8) are objects ``indices`` of the global heap collection at
        ``heap_address``."""
        if self.strings is None:
            data = self.data
        else:  # (size, collection, index) a string; an empty string all zeros
            references = np.zeros(len(self.strings), _REFERENCE)
            references["size"] = [len(s) for s in encoded]
            references["collection"] = np.where(references["size"] > 0, heap_address, 0)
            references["index"] = indices
            data = references.tobytes()
        datatype, dataspace = _datatype(self.kind), _dataspace(self.shape)
        try:
            name = self.name.encode("ascii") + b"\0"
        except UnicodeEncodeError:
            name = self.name.encode("utf-8") + b"\0"
            head = struct.pack("<BBHHHB", 3, 0, len(name), len(datatype), len(dataspace), 1)
            return ATTRIBUTE, head + name + datatype + dataspace + data
        head = struct.pack("<BBHHH", 1, 0, len(name), len(datatype), len(dataspace))
        return ATTRIBUTE, head + _pad8(name) + _pad8(datatype) + _pad8(dataspace) + data


_HEAP_OBJECT = struct.Struct("<HHIQ")  # a global heap object's header: index, references, reserved, size
_PADS = [bytes(k) for k in range(8)]
_REFERENCE = np.dtype([("size", "<u4"), ("collection", "<u8"), ("index", "<u4")])  # a variable-length value


def _global_heap(strings: list[bytes]) -> tuple[bytes, list[int]]:
    """A global heap collection holding ``strings`` (the empty ones are not stored): its bytes (to
    be written at its address) and each string's object index (0 for an empty one)."""
    parts, indices, k = [b""], [], 0
    for s in strings:
        if s:
            k += 1
            parts += (_HEAP_OBJECT.pack(k, 1, 0, len(s)), s, _PADS[-len(s) % 8])
        indices.append(k if s else 0)
    body = b"".join(parts)
    size = max(GLOBAL_HEAP_MIN, 16 + len(body) + 16)
    free = size - 16 - len(body)  # the free-space object (index 0): its size counts its own header
    return struct.pack("<4sB3xQ", b"GCOL", 1, size) + body + _HEAP_OBJECT.pack(0, 0, 0, free) + \
        bytes(free - 16), indices


def fits(name: str, value) -> bool:
    """Whether an attribute ``name`` = ``value`` fits one object header message (65535 bytes: a list
    of at most 4092 strings): what :class:`TooLarge` refuses at a flush."""
    attribute = _Attribute(name, value)
    encoded = [s.encode("utf-8") for s in attribute.strings] if attribute.strings is not None else []
    return len(_pad8(attribute.message(0, [0] * len(encoded), encoded)[1])) <= MESSAGE_MAX


# ----------------------------------------------------------------------------- objects
def _big(attribute: _Attribute) -> bool:
    """Whether an attribute goes to the chunk written once (variable-length strings, or long values)."""
    return attribute.strings is not None or len(attribute.data) > 64


class _Object:
    def __init__(self, file: "File"):
        self.file = file
        self.attrs: dict[str, _Attribute] = {}
        self.links = 0  # hard links to it (its reference count)
        self._attribute_chunk = None  # (names, address, length, count): big attributes, written once

    def set_attribute(self, name: str, value) -> None:
        """``attrs[name] = value`` as h5py stores it: str and lists of str as variable-length UTF-8
        strings, ``np.bytes_`` as a fixed-length ASCII string, an empty list as float64 (0,), numbers
        and NumPy arrays as their type."""
        attribute = self.attrs[str(name)] = _Attribute(str(name), value)
        self.file._changed = True
        if self._attribute_chunk is not None and (name in self._attribute_chunk[0] or _big(attribute)):
            self._attribute_chunk = None  # written anew with it at the next flush

    def _attribute_messages(self) -> tuple[list[bytes], tuple | None]:
        """The attribute messages kept in the header, and the continuation (address, length, count)
        of those written once (variable-length values: their heap and message written at the first
        flush that has them)."""
        big = [a for a in self.attrs.values() if _big(a)]
        if self._attribute_chunk is None and big:  # one heap for the object's strings
            encoded = [[s.encode("utf-8") for s in a.strings] if a.strings is not None else [] for a in big]
            every = [s for strings in encoded for s in strings]
            heap, indices = _global_heap(every) if any(every) else (None, [0] * len(every))
            heap_address = self.file._append(heap) if heap is not None else 0
            messages, start = [], 0
            for attribute, strings in zip(big, encoded):
                messages.append(attribute.message(heap_address, indices[start:start + len(strings)], strings))
                start += len(strings)
            version = self.file.header_version
            chunk = b"".join(_message(kind, data, version) for kind, data in messages)
            if version == 2:
                chunk = _checksummed(b"OCHK" + chunk)
            self._attribute_chunk = (frozenset(a.name for a in big), self.file._append(chunk), len(chunk), len(messages))
        kept = [a.message() for a in self.attrs.values() if a not in big]
        return kept, self._attribute_chunk if big else None

    def _header(self, messages: list[tuple[int, bytes]]) -> bytes:
        """The object header of ``messages`` (type, data) and the attributes: version 1, or version 2
        (no times stored; the reference count in a message where it is not 1) as the file asks."""
        kept, continuation = self._attribute_messages()
        messages = messages + kept
        version = self.file.header_version
        if version == 2:  # Attribute Info (no dense storage): HDF5 counts a version 2 header's attributes by it
            messages.append((ATTRIBUTE_INFO, struct.pack("<BBQQ", 0, 0, UNDEFINED, UNDEFINED)))
            if self.links > 1:
                messages.append((REFERENCE_COUNT, struct.pack("<BI", 0, self.links)))
        count = len(messages)
        if continuation is not None:
            messages.append((CONTINUATION, struct.pack("<QQ", continuation[1], continuation[2])))
            count += 1 + continuation[3]
        body = b"".join(_message(kind, data, version) for kind, data in messages)
        if version == 1:
            return struct.pack("<BBHII4x", 1, 0, count, max(1, self.links), len(body)) + body
        return _checksummed(struct.pack("<4sBBI", b"OHDR", 2, 2, len(body)) + body)


class Group(_Object):
    """A group: its links by name (hard links to groups and datasets), its attributes."""

    def __init__(self, file: "File"):
        super().__init__(file)
        self.children: dict[str, _Object] = {}

    def create_group(self, name: str) -> "Group":
        return self.link(name, Group(self.file))

    def create_dataset(self, name: str, data) -> "Dataset":
        """A contiguous dataset of ``data`` (its dtype, shape; written now), as ``group[name] = data``."""
        return self.link(name, Dataset(self.file, np.asarray(data)))

    def create_growing(self, name: str, width: tuple, dtype, chunks: tuple, fillvalue=None) -> "Dataset":
        """An extensible chunked dataset of shape ``(0, *width)``, maximum ``(None, *width)``: h5py's
        ``create_dataset(name, shape=(0, *width), maxshape=(None, *width), dtype=dtype, chunks=chunks,
        fillvalue=fillvalue)`` without times tracked. The chunks span ``width`` (``chunks[1:] == width``)."""
        return self.link(name, Dataset(self.file, None, tuple(width), np.dtype(dtype), tuple(chunks), fillvalue))

    def link(self, name: str, obj: _Object) -> _Object:
        """A hard link ``name`` to ``obj`` (``group[name] = obj``; a path's groups are created)."""
        head, _, rest = name.partition("/")
        if rest:
            group = self.children.get(head)
            if group is None:
                group = self.create_group(head)
            return group.link(rest, obj)
        if not name or name in self.children:
            raise ValueError(f"link name {name!r}: empty or taken")
        self.children[name] = obj
        obj.links += 1
        self.file._changed = True
        return obj

    def __getitem__(self, path: str) -> _Object:
        obj = self
        for part in path.split("/"):
            obj = obj.children[part]
        return obj

    def _encode(self, address_of) -> bytes:
        messages = [(LINK_INFO, struct.pack("<BBQQ", 0, 0, UNDEFINED, UNDEFINED)), (GROUP_INFO, b"\0\0")]
        for name in sorted(self.children):  # as HDF5 lists them: by name
            try:
                encoded, charset = name.encode("ascii"), None
            except UnicodeEncodeError:
                encoded, charset = name.encode("utf-8"), 1
            size_flag, length = (0, struct.pack("<B", len(encoded))) if len(encoded) < 256 else \
                (1, struct.pack("<H", len(encoded)))
            flags = size_flag | (0x10 if charset else 0)
            data = struct.pack("<BB", 1, flags) + (struct.pack("<B", charset) if charset else b"") + length + \
                encoded + struct.pack("<Q", address_of(self.children[name]))
            messages.append((LINK, data))
        return self._header(messages)


class Dataset(_Object):
    """A dataset: contiguous (its data written once) or chunked and growing (:meth:`append`)."""

    def __init__(self, file, data, width=None, dtype=None, chunks=None, fillvalue=None):
        super().__init__(file)
        if data is not None:  # contiguous, written now
            array = np.asarray(data, dtype=data.dtype.newbyteorder("<"))
            _datatype(array.dtype)
            self.dtype, self._fixed_shape, self.chunks, self.fillvalue = array.dtype, array.shape, None, None
            self.address = file._append(array.tobytes()) if array.size else UNDEFINED
            self.size = array.nbytes
            return
        if tuple(chunks[1:]) != tuple(width):
            raise ValueError(f"chunks {chunks} must span the width {width}")
        _datatype(dtype)
        self.dtype, self.width, self.chunks, self.fillvalue = dtype, width, chunks, fillvalue
        self.rows = 0
        self.chunk_rows = int(chunks[0])
        self.row_bytes = dtype.itemsize * int(np.prod(width, dtype=np.int64))
        self.chunk_addresses: list[int] = []
        fill = np.zeros((), dtype) if fillvalue is None else np.array(fillvalue, dtype)
        self._fill_chunk = np.full(self.chunk_rows * max(1, self.row_bytes // dtype.itemsize), fill, dtype).tobytes()
        self._btree = None  # (chunks indexed, address)

    @property
    def shape(self) -> tuple:
        return self._fixed_shape if self.chunks is None else (self.rows, *self.width)

    def append(self, array) -> None:
        """Rows ``array`` (n, *width) after the last (their chunks written in place; a new chunk is
        allocated whole at the end of the file)."""
        array = np.ascontiguousarray(array, dtype=self.dtype)
        n = len(array)
        if array.shape[1:] != tuple(self.width):
            raise ValueError(f"rows of shape {array.shape[1:]}, the dataset's are {self.width}")
        data = memoryview(array.reshape(-1).view(np.uint8))
        row, end = self.rows, self.rows + n
        while row < end:
            index, first = divmod(row, self.chunk_rows)
            stop = min(end, (index + 1) * self.chunk_rows)
            piece = data[(row - self.rows) * self.row_bytes:(stop - self.rows) * self.row_bytes]
            if index == len(self.chunk_addresses):  # the piece and the fill value around it, no whole copy
                start, end_ = first * self.row_bytes, first * self.row_bytes + len(piece)
                fill = memoryview(self._fill_chunk)
                self.chunk_addresses.append(self.file._append_parts((fill[:start], piece, fill[end_:])))
            else:
                self.file._write(self.chunk_addresses[index] + first * self.row_bytes, piece)
            row = stop
        self.rows = end
        self.file._changed = True

    def grow(self, n: int) -> None:
        """``n`` rows of the fill value after the last (the chunks they need allocated; a chunk is
        allocated holding the fill value)."""
        end = self.rows + n
        while len(self.chunk_addresses) * self.chunk_rows < end:
            self.chunk_addresses.append(self.file._append(self._fill_chunk))
        self.rows = end
        self.file._changed = True

    def _chunk_index(self) -> int:
        """The address of the chunks' B-tree (written anew when a chunk was added)."""
        count = -(-self.rows // self.chunk_rows)
        if self._btree is None or self._btree[0] != count:
            self._btree = (count, self.file._btree(self.chunk_addresses[:count], self.chunk_rows, len(self.width) + 1,
                                                   self.chunk_rows * self.row_bytes))
        return self._btree[1]

    def _encode(self, address_of) -> bytes:
        item = self.dtype.itemsize
        if self.fillvalue is None:
            fill = struct.pack("<BBBBI", 2, 2 if self.chunks is None else 3, 2, 1, 0)
        else:
            value = np.array(self.fillvalue, self.dtype).tobytes()
            fill = struct.pack("<BBBBI", 2, 3, 2, 1, len(value)) + value
        if self.chunks is None:
            space = _dataspace(self.shape)
            layout = struct.pack("<BBQQ", 3, 1, self.address, self.size)
        else:
            space = _dataspace(self.shape, (None, *self.width))
            dims = b"".join(struct.pack("<I", int(n)) for n in (*self.chunks, item))
            layout = struct.pack("<BBBQ", 3, 2, len(self.chunks) + 1, self._chunk_index()) + dims
        return self._header([(DATASPACE, space), (DATATYPE, _datatype(self.dtype)), (FILL_VALUE, fill),
                             (LAYOUT, layout)])


# ----------------------------------------------------------------------------- the file
class File:
    """A new HDF5 file at ``path`` (truncated), its root group :attr:`root`; :meth:`flush` makes what
    was written so far a complete file; :meth:`close` flushes and closes."""

    def __init__(self, path, header_version: int = 1):
        if header_version not in (1, 2):
            raise ValueError(f"object header version {header_version}: 1 or 2")
        self.path = Path(path)
        self.header_version = header_version
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC | _BINARY, 0o666)
        self._eof = SUPERBLOCK_SIZE
        self._write(0, bytes(SUPERBLOCK_SIZE))  # no signature until the first flush
        self.root = Group(self)
        self.root.links = 1
        self._areas = [(0, 0), (0, 0)]  # the two metadata areas: (address, capacity)
        self._current = 1  # the area the superblock points at (the other is written next)
        self._flushed = False
        self._changed = True  # something written or set since the last flush
        self._synced = False  # the last flush was synced to the disk
        self._leaves: dict = {}  # full B-tree leaves already written: their entries -> address

    # -- space
    def _append(self, data: bytes) -> int:
        """``data`` written at the end of the file (8-byte aligned); its address."""
        address = self._eof
        self._write(address, _pad8(bytes(data)))  # the file ends where the superblock says
        self._eof = address + len(data) + (-len(data) % 8)
        return address

    def _append_parts(self, parts) -> int:
        """The bytes of ``parts`` (bytes-like, one after the other) written at the end of the file (8-byte
        aligned), as :meth:`_append` of them joined; its address."""
        address, size = self._eof, sum(len(part) for part in parts)
        parts = [part for part in parts if len(part)] + [_PADS[-size % 8]]
        if _PWRITEV:
            os.pwritev(self._fd, parts, address)  # the system writes it all (a regular file) or raises
        else:
            self._write(address, b"".join(parts))
        self._eof = address + size + (-size % 8)
        self._changed = True
        return address

    def _write(self, address: int, data) -> None:
        """``data`` written at ``address`` (``os.pwrite``; a seek and a write where there is none)."""
        if _PWRITE:
            os.pwrite(self._fd, data, address)
            self._changed = True
            return
        os.lseek(self._fd, address, os.SEEK_SET)
        view = memoryview(data)
        while len(view):
            view = view[os.write(self._fd, view):]
        self._changed = True

    def _btree(self, chunks: list[int], chunk_rows: int, rank: int, chunk_bytes: int) -> int:
        """A version 1 B-tree (type 1: chunks) over ``chunks`` (addresses, one a chunk of ``chunk_rows``
        rows, in order) of a dataset of ``rank`` dimensions; its root's address. Full leaves are
        written once and kept."""
        entries = 2 * CHUNK_BTREE_K
        key_size = 8 + 8 * (rank + 1)

        def key(row):
            return struct.pack("<II", chunk_bytes, 0) + struct.pack("<Q", row) + bytes(8 * rank)

        node_size = 24 + (entries + 1) * key_size + entries * 8

        def node(level, children):  # children: (first row, end row, address)
            body = b"".join(key(first) + struct.pack("<Q", address) for first, _, address in children)
            body += key(children[-1][1])
            head = struct.pack("<4sBBHQQ", b"TREE", 1, level, len(children), UNDEFINED, UNDEFINED)
            return (head + body).ljust(node_size, b"\0")

        level_nodes = [(i * chunk_rows, (i + 1) * chunk_rows, a) for i, a in enumerate(chunks)]
        level = 0
        while True:
            groups = [level_nodes[i:i + entries] for i in range(0, len(level_nodes), entries)] or [[]]
            written = []
            for children in groups:
                if not children:  # no chunk: an empty leaf
                    data = struct.pack("<4sBBHQQ", b"TREE", 1, 0, 0, UNDEFINED, UNDEFINED).ljust(node_size, b"\0")
                    return self._append(data)
                marker = (level, chunk_bytes, rank, tuple(children))
                address = self._leaves.get(marker)
                if address is None:
                    address = self._append(node(level, children))
                    if len(children) == entries:
                        self._leaves[marker] = address
                written.append((children[0][0], children[-1][1], address))
            if len(written) == 1:
                return written[0][2]
            level_nodes, level = written, level + 1

    # -- flushing
    def flush(self, durable: bool = False) -> None:
        """Everything written so far, a complete file: the object headers into the metadata area the
        superblock does not point at, then the superblock (module docstring). ``durable``: synced to
        the disk before (but at the first flush) and after the superblock. Nothing written or set since the
        last flush: nothing is written again (a durable flush syncs the file where the last was not)."""
        if not self._changed:
            if durable and not self._synced:
                os.fsync(self._fd)
                self._synced = True
            return
        area = 1 - self._current
        address, capacity = self._areas[area]
        if capacity == 0:  # the area is new: at the end of the file once what the headers point at is there
            self._prepare(self.root, set())
            address = self._eof
        base = address
        blob = self._metadata(base)
        if len(blob) > capacity:  # a new area at the end of the file, room to grow (the other too, if unused)
            for which in (area, 1 - area) if self._areas[1 - area][1] == 0 else (area,):
                address, capacity = self._eof, 2 * len(blob) + 512
                self._eof += capacity
                self._write(address, bytes(capacity))  # the area's end is in the file
                self._areas[which] = (address, capacity)
            address, capacity = self._areas[area]
            if address != base:  # encoded for another place
                blob = self._metadata(address)
        self._write(address, blob)
        root = address + self._root_offset
        if durable and self._flushed:  # (a first flush has no earlier file to keep)
            os.fsync(self._fd)
        superblock = SIGNATURE + bytes([0, 0, 0, 0, 0, 8, 8, 0]) + struct.pack("<HHI", 4, 16, 0) + \
            struct.pack("<QQQQ", 0, UNDEFINED, self._eof, UNDEFINED) + struct.pack("<QQII16x", 0, root, 0, 0)
        self._write(0, superblock)
        if durable:
            os.fsync(self._fd)
        self._current, self._flushed = area, True
        self._changed, self._synced = False, durable

    def _prepare(self, obj: _Object, seen: set) -> None:
        """What the object headers point at written at the end of the file (the chunks' B-trees, the
        attributes' heaps and chunks) in the order :meth:`_metadata` writes it, so that a new metadata
        area after it is where the headers are encoded for (one encoding, not two)."""
        if id(obj) in seen:
            return
        seen.add(id(obj))
        if isinstance(obj, Group):
            for name in sorted(obj.children):  # as Group._encode walks them
                self._prepare(obj.children[name], seen)
        elif obj.chunks is not None:
            obj._chunk_index()
        obj._attribute_messages()

    def _metadata(self, base: int) -> bytes:
        """The object headers of every object reachable from the root (children before parents), as
        one block at ``base``; sets ``_root_offset``."""
        out, where = bytearray(), {}

        def address_of(obj):
            if id(obj) not in where:
                data = obj._encode(address_of) if isinstance(obj, Group) else obj._encode(None)
                out.extend(b"\0" * (-len(out) % 8))
                where[id(obj)] = base + len(out)
                out.extend(data)
            return where[id(obj)]

        self._root_offset = address_of(self.root) - base
        return bytes(out)

    def rename(self, path) -> None:
        """The file takes the name ``path`` (replacing a file there), kept open (closed, renamed and
        opened again where the platform renames no open file)."""
        path = Path(path)
        try:
            self.path.replace(path)
        except OSError:
            os.close(self._fd)
            self._fd = None
            self.path.replace(path)
            self._fd = os.open(path, os.O_RDWR | _BINARY)
        self.path = path

    def close(self, durable: bool = False) -> None:
        if self._fd is not None:
            try:
                self.flush(durable)
            finally:
                os.close(self._fd)
                self._fd = None
