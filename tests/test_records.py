"""latdyn.records.record: the class ``@dataclass`` makes, with the same repr, equality and hash (made without
``exec``; docs/performance.md, "Twelfth pass: latdyn's own part of the lattice process")."""
from __future__ import annotations

import dataclasses
import inspect
import pickle
from dataclasses import dataclass, field

import numpy as np
import pytest

import latdyn
from latdyn.records import record
from latdyn.scene.loader import JointFriction, Scene, Solve, StopContact


def _pair(frozen=False, explicit_hash=False, own_repr=False):
    """The same class body made by ``dataclass`` and by ``record``."""
    made = []
    for decorate in (dataclass(frozen=frozen), record(frozen=frozen)):
        class Thing:
            """A thing."""

            a: float
            b: object = None
            hidden: int = field(default=3, repr=False)
            ignored: int = field(default=4, compare=False)
            hashed_only: int = field(default=5, compare=False, hash=True)
            listed: list = field(default_factory=list)

            if explicit_hash:
                def __hash__(self):
                    return 17

            if own_repr:
                def __repr__(self):
                    return "mine"

        made.append(decorate(Thing))
    return made


@pytest.mark.parametrize("frozen", [False, True])
@pytest.mark.parametrize("explicit_hash", [False, True])
@pytest.mark.parametrize("own_repr", [False, True])
def test_a_record_is_the_dataclass_in_repr_equality_hash_and_signature(frozen, explicit_hash, own_repr):
    dc, rec = _pair(frozen, explicit_hash, own_repr)
    values = [(1.0, "x", 7, 8, 9, [1]), (1.0, "x", 0, 0, 0, [1]), (2.0, None, 3, 4, 5, []), (np.nan, (1, 2), 3, 4, 5, [])]
    for args in values:
        for other in values:
            assert repr(rec(*args)) == repr(dc(*args))
            assert (rec(*args) == rec(*other)) is (dc(*args) == dc(*other))
            assert (rec(*args) != rec(*other)) is (dc(*args) != dc(*other))
        if dc.__hash__ is None:
            assert rec.__hash__ is None
            with pytest.raises(TypeError, match="unhashable type: 'Thing'"):
                hash(rec(*args))
        elif not any(isinstance(v, list) for v in args):
            assert hash(rec(*args)) == hash(dc(*args))
    assert rec(1.0).__eq__(dc(1.0)) is NotImplemented and rec(1.0) != dc(1.0)
    assert str(inspect.signature(rec)) == str(inspect.signature(dc)) and rec.__doc__ == dc.__doc__
    assert [f.name for f in dataclasses.fields(rec)] == [f.name for f in dataclasses.fields(dc)]
    assert rec.__dataclass_params__.repr and rec.__dataclass_params__.eq
    assert rec.__dataclass_params__.frozen is frozen
    assert dataclasses.replace(rec(1.0, "x"), b="y") == rec(1.0, "y")
    assert dataclasses.asdict(rec(1.0, "x")) == dataclasses.asdict(dc(1.0, "x"))
    if frozen:
        with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'a'"):
            rec(1.0).a = 2.0


def test_a_record_in_its_own_repr_shows_dots_as_the_dataclass_does():
    dc, rec = _pair()
    thing = "_pair.<locals>.Thing"
    assert repr(rec(1.0, rec(2.0))) == repr(dc(1.0, dc(2.0))) == f"{thing}(a=1.0, b={thing}(a=2.0, b=None, ignored=4, " \
        "hashed_only=5, listed=[]), ignored=4, hashed_only=5, listed=[])"
    looped_dc, looped_rec = dc(1.0), rec(1.0)
    looped_dc.b, looped_rec.b = looped_dc, looped_rec
    assert repr(looped_rec) == repr(looped_dc) == f"{thing}(a=1.0, b=..., ignored=4, hashed_only=5, listed=[])"


def test_arrays_in_records_compare_as_in_dataclasses():
    dc, rec = _pair()
    for cls in (dc, rec):
        same = np.zeros(3)
        assert cls(1.0, same) == cls(1.0, same)  # the same object: the tuples' identity test
        with pytest.raises(ValueError, match="truth value of an array"):
            cls(1.0, np.zeros(3)) == cls(1.0, np.zeros(3))  # noqa: B015


def test_the_scenes_records_compare_pickle_and_show_as_before(tmp_path):
    scene = latdyn.load_scene(latdyn.__file__.replace("__init__.py", "examples/spinup.yaml"))
    again = latdyn.load_scene(latdyn.__file__.replace("__init__.py", "examples/spinup.yaml"))
    assert isinstance(scene, Scene) and scene.solve == again.solve and scene.output == again.output
    assert repr(scene.solve).startswith("Solve(analysis='transient', t_end=")
    assert pickle.loads(pickle.dumps(scene.solve)) == scene.solve
    assert Solve.__hash__ is None
    friction = JointFriction(coulomb=1.0, static=1.5, stribeck_rate=0.1, viscous=0.0, stick_rate=1e-3)
    assert hash(friction) == hash(JointFriction(1.0, 1.5, 0.1, 0.0, 1e-3)) and {friction, friction} == {friction}
    assert hash(StopContact(1.0, 2.0, 0.5)) == hash((1.0, 2.0, 0.5))
