"""The slave inside an FMU that ``latdyn fmu`` builds (:mod:`latdyn.stepping.fmu`): FMI 2.0
co-simulation through PythonFMU's ``Fmi2Slave``, on a :class:`~latdyn.stepping.simulation.Simulation`
of the scene the FMU carries in its resources (:data:`SCENE_RESOURCE`).

Its real inputs are the scene's ``inputs`` (start values the scene's), its real outputs the
scene's probes (file order). ``fmi2DoStep(t, h)`` sets the inputs' current values and advances
the run to t + h (:meth:`Simulation.advance_to`: the steps land on the communication points);
the outputs are the probes there. The default experiment is 0 … ``solve.t_end`` with a
communication step of ``output.every`` (else ``solve.dt``). A step the run cannot take (past
``solve.t_end``, a solver failure) is logged with status error, naming what was wrong, and ends the
FMU with fmi2Fatal (PythonFMU reports an exception so; its only other failure, fmi2Discard, FMPy
takes as a quiet early stop). The run ends (``fmi2Terminate``) with :meth:`Simulation.close`. It
runs in the Python that loads the FMU: that Python needs latdyn (PythonFMU's runtime is carried in
the FMU)."""
from __future__ import annotations

from pathlib import Path

from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

from latdyn.scene.loader import load_scene
from latdyn.stepping.fmu import SCENE_RESOURCE
from latdyn.stepping.simulation import Simulation


#: The namespaces of the slave modules, one reference per execution of their source.
_HELD: list[dict] = []


def hold_module_namespace(namespace: dict) -> None:
    """Keep one more reference to the slave module's namespace. PythonFMU's loader (0.6.5 … 0.7,
    ``findClass`` in PySlaveInstance.cpp) runs the module's source again in its namespace for every
    instance it creates and then releases that namespace, a reference it only borrowed: the second
    instance in one process found it freed ("module has no attribute", or a crash; PythonFMU issue
    #228). The module's source calls this each time it runs, which balances that release."""
    _HELD.append(namespace)


class LatdynSlave(Fmi2Slave):
    """An FMI 2.0 co-simulation slave of the scene in ``resources/scene.yaml``; ``latdyn fmu``
    names a subclass of it after the FMU (its model identifier)."""

    author = "latdyn"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.scene_file = Path(self.resources) / SCENE_RESOURCE
        scene = load_scene(str(self.scene_file))
        solve = scene.solve
        self.description = f"latdyn scene {scene.title or self.scene_file.name}"
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=float(solve.t_end),
                                                    step_size=float(scene.output.every or solve.dt))
        self.inputs = scene.inputs.current()  # latdyn.scene.inputs.Inputs
        self.probe_names = [p.name for p in scene.output.probes]
        self.simulation: Simulation | None = None
        self.outputs: dict[str, float] = {}
        for name in self.inputs:
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        getter=lambda name=name: self.inputs[name],
                                        setter=lambda value, name=name: self.inputs.__setitem__(name, float(value))),
                                   nested=False)
        for name in self.probe_names:
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        getter=lambda name=name: self.output(name)), nested=False)

    def started(self) -> Simulation:
        """The run (started at the first output read or step, with the inputs set by then)."""
        if self.simulation is None:
            self.simulation = Simulation(self.scene_file)
            self.push_inputs()
            self.outputs = self.simulation.probes()
        return self.simulation

    def push_inputs(self) -> None:
        for name, value in self.inputs.items():
            self.simulation.set_input(name, value)

    def output(self, name: str) -> float:
        self.started()
        return self.outputs[name]

    def exit_initialization_mode(self):
        self.started()

    def do_step(self, current_time: float, step_size: float) -> bool:
        simulation = self.started()
        try:
            self.push_inputs()
            simulation.advance_to(current_time + step_size)
        except Exception as failure:  # the importer hears of it as fmi2Error, its message logged
            self.log(f"latdyn: {type(failure).__name__}: {failure}", Fmi2Status.error)
            raise
        self.outputs = simulation.probes()
        return True

    def terminate(self):
        if self.simulation is not None:
            self.simulation.close()
