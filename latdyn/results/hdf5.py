"""HDF5 files written through the HDF5 C library itself (``ctypes``), as h5py writes them.

The run's HDF5 files (``state.h5``, the ParaView parts' VTKHDF files) are written here rather than
through h5py: a fresh process loads the library in ~2 ms where ``import h5py`` takes ~20 ms
(docs/performance.md, "Tenth pass"), and each call is one C call. The library is the one h5py
uses — its wheel's copy (``site-packages/h5py.libs/libhdf5-*.so``, found without importing h5py) —
else the system's (``ctypes.util.find_library``), else the file named by ``LATDYN_HDF5_LIBRARY``
(which also comes first). What is written is what h5py writes with the options latdyn gives it: the
same objects, types (file types little-endian IEEE/two's complement, strings as h5py stores
them), dataspaces, chunks, fill values, no times tracked, links with the character set of their
names (tests/test_hdf5_files.py compares them object by object). Reading results (``Result``,
the tests) still goes through h5py.

Only what the writers need: files, groups, datasets (contiguous with data, or chunked and
extensible), hyperslab writes, attributes, hard links, and for resuming, lookups (a group's
names, a dataset's shape, an attribute's value). Identifiers are plain ``int`` (``hid_t``);
:meth:`Library.close_file` closes a file with every object still open in it.
An error of the library raises :class:`OSError` with the library's messages, innermost last.
"""
from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np

__all__ = ["HDF5Missing", "library", "available"]

#: H5public.h / H5Fpublic.h / H5Spublic.h / H5Tpublic.h constants (stable since HDF5 1.10)
DEFAULT = 0  # H5P_DEFAULT, H5S_ALL, H5E_DEFAULT
ACC_RDONLY, ACC_RDWR, ACC_TRUNC = 0, 1, 2
OBJ_DATASET, OBJ_GROUP, OBJ_DATATYPE, OBJ_ATTR, OBJ_LOCAL = 2, 4, 8, 16, 32  # H5F_OBJ_*
LIBVER_EARLIEST, LIBVER_V18 = 0, 1
UNLIMITED = ctypes.c_uint64(-1).value  # H5S_UNLIMITED
VARIABLE = ctypes.c_size_t(-1).value  # H5T_VARIABLE
SCALAR = 0  # H5S_SCALAR
SELECT_SET = 0  # H5S_SELECT_SET
CSET_ASCII, CSET_UTF8 = 0, 1
STR_NULLPAD = 1
INDEX_NAME, ITER_INC = 0, 0  # H5_INDEX_NAME, H5_ITER_INC
WALK_DOWNWARD = 0

hid_t, herr_t, hsize_t = ctypes.c_int64, ctypes.c_int, ctypes.c_uint64
_p = ctypes.c_void_p

#: the prototypes used: name -> (result, arguments)
PROTOTYPES = {
    "H5open": (herr_t, []),
    "H5get_libversion": (herr_t, [ctypes.POINTER(ctypes.c_uint)] * 3),
    "H5Eset_auto2": (herr_t, [hid_t, _p, _p]),
    "H5Ewalk2": (herr_t, [hid_t, ctypes.c_int, _p, _p]),
    "H5Eclear2": (herr_t, [hid_t]),
    "H5Pcreate": (hid_t, [hid_t]),
    "H5Pclose": (herr_t, [hid_t]),
    "H5Pset_libver_bounds": (herr_t, [hid_t, ctypes.c_int, ctypes.c_int]),
    "H5Pset_fclose_degree": (herr_t, [hid_t, ctypes.c_int]),
    "H5Pset_file_locking": (herr_t, [hid_t, ctypes.c_bool, ctypes.c_bool]),
    "H5Pset_obj_track_times": (herr_t, [hid_t, ctypes.c_bool]),
    "H5Pset_chunk": (herr_t, [hid_t, ctypes.c_int, _p]),
    "H5Pset_fill_value": (herr_t, [hid_t, hid_t, _p]),
    "H5Pset_create_intermediate_group": (herr_t, [hid_t, ctypes.c_uint]),
    "H5Pset_char_encoding": (herr_t, [hid_t, ctypes.c_int]),
    "H5Fcreate": (hid_t, [ctypes.c_char_p, ctypes.c_uint, hid_t, hid_t]),
    "H5Fopen": (hid_t, [ctypes.c_char_p, ctypes.c_uint, hid_t]),
    "H5Fflush": (herr_t, [hid_t, ctypes.c_int]),
    "H5Fclose": (herr_t, [hid_t]),
    "H5Fget_obj_count": (ctypes.c_ssize_t, [hid_t, ctypes.c_uint]),
    "H5Fget_obj_ids": (ctypes.c_ssize_t, [hid_t, ctypes.c_uint, ctypes.c_size_t, _p]),
    "H5Oclose": (herr_t, [hid_t]),
    "H5Gcreate2": (hid_t, [hid_t, ctypes.c_char_p, hid_t, hid_t, hid_t]),
    "H5Gopen2": (hid_t, [hid_t, ctypes.c_char_p, hid_t]),
    "H5Gclose": (herr_t, [hid_t]),
    "H5Gget_info": (herr_t, [hid_t, _p]),
    "H5Lget_name_by_idx": (ctypes.c_ssize_t, [hid_t, ctypes.c_char_p, ctypes.c_int, ctypes.c_int, hsize_t,
                                              ctypes.c_char_p, ctypes.c_size_t, hid_t]),
    "H5Lcreate_hard": (herr_t, [hid_t, ctypes.c_char_p, hid_t, ctypes.c_char_p, hid_t, hid_t]),
    "H5Dcreate2": (hid_t, [hid_t, ctypes.c_char_p, hid_t, hid_t, hid_t, hid_t, hid_t]),
    "H5Dopen2": (hid_t, [hid_t, ctypes.c_char_p, hid_t]),
    "H5Dclose": (herr_t, [hid_t]),
    "H5Dget_space": (hid_t, [hid_t]),
    "H5Dset_extent": (herr_t, [hid_t, _p]),
    "H5Dwrite": (herr_t, [hid_t, hid_t, hid_t, hid_t, hid_t, _p]),
    "H5Screate": (hid_t, [ctypes.c_int]),
    "H5Screate_simple": (hid_t, [ctypes.c_int, _p, _p]),
    "H5Sget_simple_extent_ndims": (ctypes.c_int, [hid_t]),
    "H5Sget_simple_extent_dims": (ctypes.c_int, [hid_t, _p, _p]),
    "H5Sselect_hyperslab": (herr_t, [hid_t, ctypes.c_int, _p, _p, _p, _p]),
    "H5Sclose": (herr_t, [hid_t]),
    "H5Tcopy": (hid_t, [hid_t]),
    "H5Tset_size": (herr_t, [hid_t, ctypes.c_size_t]),
    "H5Tset_cset": (herr_t, [hid_t, ctypes.c_int]),
    "H5Tset_strpad": (herr_t, [hid_t, ctypes.c_int]),
    "H5Tclose": (herr_t, [hid_t]),
    "H5Acreate2": (hid_t, [hid_t, ctypes.c_char_p, hid_t, hid_t, hid_t, hid_t]),
    "H5Aopen": (hid_t, [hid_t, ctypes.c_char_p, hid_t]),
    "H5Awrite": (herr_t, [hid_t, hid_t, _p]),
    "H5Aread": (herr_t, [hid_t, hid_t, _p]),
    "H5Aclose": (herr_t, [hid_t]),
}
#: the library's global identifiers read after H5open: our name -> the variable
GLOBALS = {
    "FILE_CREATE": "H5P_CLS_FILE_CREATE_ID_g", "FILE_ACCESS": "H5P_CLS_FILE_ACCESS_ID_g",
    "DATASET_CREATE": "H5P_CLS_DATASET_CREATE_ID_g", "GROUP_CREATE": "H5P_CLS_GROUP_CREATE_ID_g",
    "LINK_CREATE": "H5P_CLS_LINK_CREATE_ID_g", "C_S1": "H5T_C_S1_g",
    **{f"NATIVE_{kind}{bits}": f"H5T_NATIVE_{kind}{bits}_g" for kind in ("INT", "UINT") for bits in (8, 16, 32, 64)},
    **{f"STD_{kind}{bits}LE": f"H5T_STD_{kind}{bits}LE_g" for kind in "IU" for bits in (8, 16, 32, 64)},
    "NATIVE_FLOAT": "H5T_NATIVE_FLOAT_g", "NATIVE_DOUBLE": "H5T_NATIVE_DOUBLE_g",
    "IEEE_F32LE": "H5T_IEEE_F32LE_g", "IEEE_F64LE": "H5T_IEEE_F64LE_g",
}
#: the memory type and h5py's file type of each NumPy kind and size written (integers, floats)
DTYPES = {**{("i", n // 8): (f"NATIVE_INT{n}", f"STD_I{n}LE") for n in (8, 16, 32, 64)},
          **{("u", n // 8): (f"NATIVE_UINT{n}", f"STD_U{n}LE") for n in (8, 16, 32, 64)},
          ("f", 4): ("NATIVE_FLOAT", "IEEE_F32LE"), ("f", 8): ("NATIVE_DOUBLE", "IEEE_F64LE")}
#: H5F_LIBVER_LATEST by the library's (major, minor): the enumeration grows with the versions
LIBVER_LATEST = {(1, 10): 2, (1, 12): 3, (1, 14): 4, (2, 0): 5}
MINIMUM_VERSION = (1, 10)



class HDF5Missing(ImportError):
    """No HDF5 library could be loaded (the message says where it was looked for); an ImportError, as
    a missing h5py was."""


def _candidates() -> list[str]:
    """Where the library is looked for, in order (module docstring)."""
    from importlib.util import find_spec

    found = []
    named = os.environ.get("LATDYN_HDF5_LIBRARY")
    if named:
        found.append(named)
    try:
        spec = find_spec("h5py")
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.submodule_search_locations:
        for package in spec.submodule_search_locations:
            libs = Path(package).parent / "h5py.libs"  # a manylinux wheel's bundled libraries
            if libs.is_dir():
                found += sorted(str(p) for p in libs.glob("libhdf5-*.so*"))
                found += sorted(str(p) for p in libs.glob("libhdf5-*.dylib"))
            dylibs = Path(package) / ".dylibs"  # a macOS wheel's
            if dylibs.is_dir():
                found += sorted(str(p) for p in dylibs.glob("libhdf5.*dylib"))
    return found


def _system_candidates() -> list[str]:
    import ctypes.util

    return [name for name in (ctypes.util.find_library("hdf5"), ctypes.util.find_library("hdf5_serial")) if name]


class Library:
    """The loaded library: its functions (``lib.H5Fcreate``) and global identifiers (``lib.NATIVE_DOUBLE``)."""

    def __init__(self, path: str):
        self.path = path
        self.dll = dll = ctypes.CDLL(path)
        for name, (result, arguments) in PROTOTYPES.items():
            function = getattr(dll, name)
            function.restype, function.argtypes = result, arguments
            setattr(self, name, function)
        if dll.H5open() < 0:
            raise OSError(f"{path}: H5open failed")
        version = (ctypes.c_uint(), ctypes.c_uint(), ctypes.c_uint())
        dll.H5get_libversion(*(ctypes.byref(v) for v in version))
        self.version = tuple(v.value for v in version)
        if self.version[:2] < MINIMUM_VERSION:
            raise HDF5Missing(f"{path}: HDF5 {'.'.join(map(str, self.version))}; latdyn needs HDF5 >= 1.10")
        self.libver_latest = LIBVER_LATEST.get(self.version[:2], max(LIBVER_LATEST.values()))
        for name, symbol in GLOBALS.items():
            setattr(self, name, hid_t.in_dll(dll, symbol).value)
        self.H5Eset_auto2(DEFAULT, None, None)  # errors raised here, not printed by the library
        self._walk = ctypes.CFUNCTYPE(herr_t, ctypes.c_uint, ctypes.POINTER(_ErrorRecord), _p)(self._record)
        self._messages: list[str] = []

    # -- errors
    def _record(self, n, record, data) -> int:
        description = record.contents.desc
        self._messages.append(description.decode("utf-8", "replace") if description else "")
        return 0

    def error(self, what: str) -> OSError:
        """The library's error stack as an OSError (``what`` first), the stack cleared."""
        self._messages = []
        self.H5Ewalk2(DEFAULT, WALK_DOWNWARD, ctypes.cast(self._walk, _p), None)
        self.H5Eclear2(DEFAULT)
        detail = "; ".join(m for m in self._messages if m)
        return OSError(f"{what}: {detail}" if detail else what)

    def check(self, value: int, what: str) -> int:
        if value < 0:
            raise self.error(what)
        return value

    # -- property lists and types
    def plist(self, cls: int, **settings) -> int:
        """A property list of class ``cls`` (``FILE_ACCESS``, …) with ``settings``: name -> arguments."""
        plist = self.check(self.H5Pcreate(cls), "H5Pcreate")
        try:
            for name, arguments in settings.items():
                self.check(getattr(self, "H5Pset_" + name)(plist, *arguments), f"H5Pset_{name}")
        except BaseException:
            self.H5Pclose(plist)
            raise
        return plist

    def string_type(self, size: int | None) -> int:
        """h5py's string types: ``None`` variable-length UTF-8 (``h5py.string_dtype()``, a ``str``),
        else fixed-length ASCII of ``size`` bytes padded with NULs (``np.bytes_``)."""
        tid = self.check(self.H5Tcopy(self.C_S1), "H5Tcopy")
        if size is None:
            self.H5Tset_size(tid, VARIABLE)
            self.H5Tset_cset(tid, CSET_UTF8)
        else:
            self.H5Tset_size(tid, max(1, size))
            self.H5Tset_strpad(tid, STR_NULLPAD)
        return tid

    def types(self, dtype: np.dtype) -> tuple[int, int]:
        """The memory type and h5py's file type of a NumPy integer or float dtype."""
        try:
            memory, stored = DTYPES[dtype.kind, dtype.itemsize]
        except KeyError:
            raise ValueError(f"an HDF5 array of {dtype}: latdyn writes integers and floats only") from None
        return getattr(self, memory), getattr(self, stored)

    # -- files
    def create_file(self, path, libver_low: int = LIBVER_EARLIEST, locking: bool = True) -> int:
        """``h5py.File(path, "w", libver=(low, "latest"), locking=locking)``: the file truncated."""
        fcpl = self.plist(self.FILE_CREATE, obj_track_times=(False,))
        fapl = self._fapl(libver_low, locking)
        try:
            return self.check(self.H5Fcreate(os.fsencode(path), ACC_TRUNC, fcpl, fapl), f"{path}: cannot create the file")
        finally:
            self.H5Pclose(fcpl)
            self.H5Pclose(fapl)

    def open_file(self, path, writable: bool, libver_low: int = LIBVER_EARLIEST, locking: bool = True) -> int:
        fapl = self._fapl(libver_low, locking)
        try:
            return self.check(self.H5Fopen(os.fsencode(path), ACC_RDWR if writable else ACC_RDONLY, fapl),
                              f"{path}: cannot open the file")
        finally:
            self.H5Pclose(fapl)

    def _fapl(self, libver_low: int, locking: bool) -> int:
        # the default close degree, as h5py's: a file open twice in a process (h5py reading a file
        # being written) must be opened with the same one
        settings = {"libver_bounds": (libver_low, self.libver_latest)}
        if not locking:
            settings["file_locking"] = (False, False)
        return self.plist(self.FILE_ACCESS, **settings)

    def flush(self, fid: int) -> None:
        self.check(self.H5Fflush(fid, 1), "H5Fflush")  # H5F_SCOPE_GLOBAL

    def close_file(self, fid: int) -> None:
        """Close every object opened through ``fid`` (as ``h5py.File.close`` does), then the file."""
        for kinds, close in ((OBJ_ATTR, self.H5Aclose), (OBJ_DATASET | OBJ_GROUP | OBJ_DATATYPE, self.H5Oclose)):
            count = self.H5Fget_obj_count(fid, kinds | OBJ_LOCAL)
            if count > 0:
                ids = (hid_t * count)()
                for index in range(self.H5Fget_obj_ids(fid, kinds | OBJ_LOCAL, count, ids)):
                    close(ids[index])
        self.check(self.H5Fclose(fid), "H5Fclose")

    # -- groups and links
    def _lcpl(self, name: str) -> tuple[bytes, int]:
        """The name encoded and a link creation list as h5py makes them (intermediate groups created,
        the character set ASCII for an ASCII name, else UTF-8)."""
        try:
            encoded, charset = name.encode("ascii"), CSET_ASCII
        except UnicodeEncodeError:
            encoded, charset = name.encode("utf-8"), CSET_UTF8
        return encoded, self.plist(self.LINK_CREATE, create_intermediate_group=(1,), char_encoding=(charset,))

    def create_group(self, loc: int, name: str) -> int:
        """``group.create_group(name)`` (no times tracked); its id."""
        encoded, lcpl = self._lcpl(name)
        gcpl = self.plist(self.GROUP_CREATE, obj_track_times=(False,))
        try:
            return self.check(self.H5Gcreate2(loc, encoded, lcpl, gcpl, DEFAULT), f"cannot create group {name!r}")
        finally:
            self.H5Pclose(lcpl)
            self.H5Pclose(gcpl)

    def open_group(self, loc: int, name: str) -> int:
        return self.check(self.H5Gopen2(loc, name.encode("utf-8"), DEFAULT), f"no group {name!r}")

    def names(self, group: int) -> list[str]:
        """The names in a group, in the order h5py lists them (by name)."""
        info = _GroupInfo()
        self.check(self.H5Gget_info(group, ctypes.byref(info)), "H5Gget_info")
        out = []
        for index in range(info.nlinks):
            size = self.check(self.H5Lget_name_by_idx(group, b".", INDEX_NAME, ITER_INC, index, None, 0, DEFAULT),
                              "H5Lget_name_by_idx")
            buffer = ctypes.create_string_buffer(size + 1)
            self.H5Lget_name_by_idx(group, b".", INDEX_NAME, ITER_INC, index, buffer, size + 1, DEFAULT)
            out.append(buffer.value.decode("utf-8"))
        return out

    def link(self, group: int, name: str, target: int) -> None:
        """``group[name] = dataset``: a hard link to the object ``target``."""
        encoded, lcpl = self._lcpl(name)
        try:
            self.check(self.H5Lcreate_hard(target, b".", group, encoded, lcpl, DEFAULT), f"cannot link {name!r}")
        finally:
            self.H5Pclose(lcpl)

    def close_group(self, gid: int) -> None:
        self.check(self.H5Gclose(gid), "H5Gclose")

    # -- datasets
    def create_dataset(self, loc: int, name: str, data: np.ndarray) -> int:
        """``group[name] = data``: a contiguous dataset of ``data`` (dtype f8, i8 or u1)."""
        data = _native(data)
        memory, stored = self.types(data.dtype)
        space = self._space(data.shape)
        encoded, lcpl = self._lcpl(name)
        dcpl = self.plist(self.DATASET_CREATE, obj_track_times=(False,))
        try:
            did = self.check(self.H5Dcreate2(loc, encoded, stored, space, lcpl, dcpl, DEFAULT),
                             f"cannot create dataset {name!r}")
            if data.size:
                self.check(self.H5Dwrite(did, memory, DEFAULT, DEFAULT, DEFAULT,
                                         data.ctypes.data), f"cannot write dataset {name!r}")
            return did
        finally:
            self.H5Sclose(space)
            self.H5Pclose(lcpl)
            self.H5Pclose(dcpl)

    def create_growing(self, loc: int, name: str, width: tuple, dtype: str, chunks: tuple, fillvalue=None) -> int:
        """``group.create_dataset(name, shape=(0, *width), maxshape=(None, *width), dtype=dtype,
        chunks=chunks, fillvalue=fillvalue)``: chunked, extensible along its first axis; its id."""
        memory, stored = self.types(np.dtype(dtype))
        chunk = (hsize_t * len(chunks))(*chunks)
        settings = {"chunk": (len(chunks), chunk)}
        fill = None
        if fillvalue is not None:
            fill = np.array(fillvalue, dtype=np.dtype(dtype))
            settings["fill_value"] = (memory, fill.ctypes.data)
        settings["obj_track_times"] = (False,)
        dcpl = self.plist(self.DATASET_CREATE, **settings)
        space = self._space((0, *width), (UNLIMITED, *width))
        encoded, lcpl = self._lcpl(name)
        try:
            return self.check(self.H5Dcreate2(loc, encoded, stored, space, lcpl, dcpl, DEFAULT),
                              f"cannot create dataset {name!r}")
        finally:
            self.H5Sclose(space)
            self.H5Pclose(lcpl)
            self.H5Pclose(dcpl)

    def open_dataset(self, loc: int, path: str) -> int:
        return self.check(self.H5Dopen2(loc, path.encode("utf-8"), DEFAULT), f"no dataset {path!r}")

    def shape(self, did: int) -> tuple:
        space = self.check(self.H5Dget_space(did), "H5Dget_space")
        try:
            rank = self.H5Sget_simple_extent_ndims(space)
            dims = (hsize_t * max(1, rank))()
            self.H5Sget_simple_extent_dims(space, dims, None)
            return tuple(int(d) for d in dims[:rank])
        finally:
            self.H5Sclose(space)

    def set_extent(self, did: int, shape: tuple) -> None:
        self.check(self.H5Dset_extent(did, (hsize_t * len(shape))(*shape)), "cannot extend a dataset")

    def write_rows(self, did: int, first: int, array: np.ndarray) -> None:
        """``dataset[first:first + len(array)] = array`` (the dataset already that long)."""
        array = _native(array)
        memory = self.types(array.dtype)[0]
        memory_space = self._space(array.shape)
        file_space = self.check(self.H5Dget_space(did), "H5Dget_space")
        try:
            start = (hsize_t * array.ndim)(first, *(0 for _ in array.shape[1:]))
            count = (hsize_t * array.ndim)(*array.shape)
            self.check(self.H5Sselect_hyperslab(file_space, SELECT_SET, start, None, count, None), "H5Sselect_hyperslab")
            self.check(self.H5Dwrite(did, memory, memory_space, file_space, DEFAULT, array.ctypes.data),
                       "cannot write a dataset")
        finally:
            self.H5Sclose(memory_space)
            self.H5Sclose(file_space)

    def close_dataset(self, did: int) -> None:
        self.check(self.H5Dclose(did), "H5Dclose")

    def _space(self, shape: tuple, maxshape: tuple | None = None) -> int:
        if not shape:
            return self.check(self.H5Screate(SCALAR), "H5Screate")
        dims = (hsize_t * len(shape))(*shape)
        limits = None if maxshape is None else (hsize_t * len(maxshape))(*maxshape)
        return self.check(self.H5Screate_simple(len(shape), dims, limits), "H5Screate_simple")

    # -- attributes
    def set_attribute(self, loc: int, name: str, value) -> None:
        """``attrs[name] = value`` as h5py stores it (a new attribute): ``str`` a variable-length
        UTF-8 string, a list of ``str`` an array of them, ``np.bytes_`` a fixed-length string, a
        NumPy array or scalar of f8/i8 its numbers."""
        if isinstance(value, str) or (isinstance(value, (list, tuple)) and value
                                      and all(type(item) is str for item in value)):
            strings = [value] if isinstance(value, str) else list(value)
            encoded = [s.encode("utf-8") for s in strings]
            buffer = (ctypes.c_char_p * len(encoded))(*encoded)
            tid, shape, data, memory = self.string_type(None), (() if isinstance(value, str) else (len(strings),)), \
                buffer, None
        elif isinstance(value, np.bytes_):
            tid = self.string_type(len(value))
            shape, data, memory = (), ctypes.create_string_buffer(bytes(value), max(1, len(value))), None
        else:
            array = _native(value)
            memory, stored = self.types(array.dtype)
            tid, shape, data = self.H5Tcopy(stored), array.shape, array
        space = self._space(shape)
        try:
            aid = self.check(self.H5Acreate2(loc, name.encode("utf-8"), tid, space, DEFAULT, DEFAULT),
                             f"cannot create attribute {name!r}")
            try:
                pointer = data.ctypes.data if isinstance(data, np.ndarray) else ctypes.cast(data, _p)
                self.check(self.H5Awrite(aid, tid if memory is None else memory, pointer), f"cannot write attribute {name!r}")
            finally:
                self.H5Aclose(aid)
        finally:
            self.H5Sclose(space)
            self.H5Tclose(tid)

    def open_attribute(self, loc: int, name: str) -> int:
        return self.check(self.H5Aopen(loc, name.encode("utf-8"), DEFAULT), f"no attribute {name!r}")

    def write_int(self, aid: int, value: int) -> None:
        """A scalar 64-bit integer attribute's new value."""
        self.check(self.H5Awrite(aid, self.NATIVE_INT64, ctypes.byref(ctypes.c_int64(value))), "H5Awrite")

    def read_int(self, aid: int) -> int:
        value = ctypes.c_int64()
        self.check(self.H5Aread(aid, self.NATIVE_INT64, ctypes.byref(value)), "H5Aread")
        return value.value

    def close_attribute(self, aid: int) -> None:
        self.check(self.H5Aclose(aid), "H5Aclose")


def _native(value) -> np.ndarray:
    """``value`` as a C-contiguous array in the machine's byte order (what the memory types say)."""
    array = np.asarray(value)  # a scalar stays one (np.ascontiguousarray makes it (1,))
    if not array.flags.c_contiguous:
        array = array.copy(order="C")
    return array if array.dtype.isnative else array.astype(array.dtype.newbyteorder("="))


class _ErrorRecord(ctypes.Structure):
    """H5E_error2_t."""
    _fields_ = [("cls_id", hid_t), ("maj_num", hid_t), ("min_num", hid_t), ("line", ctypes.c_uint),
                ("func_name", ctypes.c_char_p), ("file_name", ctypes.c_char_p), ("desc", ctypes.c_char_p)]


class _GroupInfo(ctypes.Structure):
    """H5G_info_t."""
    _fields_ = [("storage_type", ctypes.c_int), ("nlinks", hsize_t), ("max_corder", ctypes.c_int64),
                ("mounted", ctypes.c_bool)]


_LIBRARY: list = []  # the Library once loaded, or the HDF5Missing raised


def library() -> Library:
    """The HDF5 library, loaded on first use; :class:`HDF5Missing` where none can be loaded."""
    if not _LIBRARY:
        tried, reasons = _candidates(), []
        system = None
        for attempt in (0, 1):
            for path in tried:
                try:
                    _LIBRARY.append(Library(path))
                    break
                except HDF5Missing as exc:
                    reasons.append(str(exc))
                except OSError as exc:
                    reasons.append(f"{path}: {exc}")
            if _LIBRARY or attempt:
                break
            system = _system_candidates()
            tried = system
        if not _LIBRARY:
            where = "; ".join(reasons) or "h5py's wheel has no h5py.libs/libhdf5-*.so and the system has no libhdf5"
            _LIBRARY.append(HDF5Missing(
                f"the HDF5 library (libhdf5) was not found ({where}): install h5py (pip install h5py), "
                "which brings it, or name the library file in LATDYN_HDF5_LIBRARY"))
    if isinstance(_LIBRARY[0], Exception):
        raise _LIBRARY[0]
    return _LIBRARY[0]


def available() -> bool:
    """Whether the library can be loaded (loading it)."""
    try:
        library()
    except HDF5Missing:
        return False
    return True
