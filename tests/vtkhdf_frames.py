"""Read a transient VTKHDF file back with VTK's own reader (``vtk.vtkHDFReader``), not ours."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest


@dataclass
class Frame:
    t: float
    points: np.ndarray  # (n_points, 3)
    cells: list  # [(VTK cell type, [point ids])]
    point_data: dict
    cell_data: dict


def times(path) -> list[float]:
    """The time steps the reader announces (TIME_STEPS of its output information)."""
    vtk = pytest.importorskip("vtk")
    reader = vtk.vtkHDFReader()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    key = vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    return [info.Get(key, i) for i in range(info.Length(key))] if info.Has(key) else []


def read_frames(path) -> list[Frame]:
    """Every time step of a VTKHDF file, each read with ``UpdateTimeStep`` (a file of one step
    has no TIME_STEPS for VTK: that frame's ``t`` is None)."""
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkHDFReader()
    reader.SetFileName(str(path))
    assert reader.CanReadFile(str(path))
    frames = []
    steps = times(path)
    if not steps:
        reader.UpdateInformation()
        steps = [None] * reader.GetNumberOfSteps()
    for t in steps:
        if t is None:
            reader.Update()
        else:
            reader.UpdateTimeStep(t)
        grid = reader.GetOutput()
        assert grid.GetClassName() == "vtkUnstructuredGrid"
        cells = []
        for i in range(grid.GetNumberOfCells()):
            ids = grid.GetCell(i).GetPointIds()
            cells.append((grid.GetCellType(i), [ids.GetId(j) for j in range(ids.GetNumberOfIds())]))

        def arrays(data):
            return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)).copy() for i in range(data.GetNumberOfArrays())}

        frames.append(Frame(t, vtk_to_numpy(grid.GetPoints().GetData()).copy() if grid.GetPoints() else np.zeros((0, 3)),
                            cells, arrays(grid.GetPointData()), arrays(grid.GetCellData())))
    return frames


def assert_same_frames(a, b) -> None:
    """Two files hold the same frames, bit for bit (NaN equal to NaN)."""
    fa, fb = read_frames(a), read_frames(b)
    assert [f.t for f in fa] == [f.t for f in fb]
    for x, y in zip(fa, fb):
        np.testing.assert_array_equal(x.points, y.points)
        assert x.cells == y.cells
        for kind in ("point_data", "cell_data"):
            assert sorted(getattr(x, kind)) == sorted(getattr(y, kind))
            for name, value in getattr(x, kind).items():
                np.testing.assert_array_equal(value, getattr(y, kind)[name])
