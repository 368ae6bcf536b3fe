"""FMUs written by `ipgen --emit fmu` / `fmu3`, loaded with FMPy's low-level API for the tests.

`Loaded` wraps one instance of an FMI 2.0 or 3.0 Model Exchange FMU behind one interface
(set values by name, states, derivatives, directional and adjoint derivatives) and collects
what the FMU logs, so that a test can check an error's message.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from pathlib import Path

import numpy as np

SYSTEMS_N = (1, 2, 3)


class Loaded:
    """One instantiated FMU in continuous-time mode (FMI `version` 2 or 3)."""

    def __init__(self, path: Path, unzipped: str, instance: str = "test", guid: str | None = None) -> None:
        from fmpy import read_model_description

        self.description = read_model_description(str(path))
        self.version = 3 if self.description.fmiVersion.startswith("3") else 2
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.messages: list[str] = []
        identifier = self.description.modelExchange.modelIdentifier
        token = guid if guid is not None else self.description.guid
        if self.version == 2:
            from fmpy import calloc, free
            from fmpy.fmi2 import (
                FMU2Model,
                fmi2CallbackAllocateMemoryTYPE,
                fmi2CallbackFreeMemoryTYPE,
                fmi2CallbackFunctions,
                fmi2CallbackLoggerTYPE,
            )
            from fmpy.logging import addLoggerProxy

            self.fmu = FMU2Model(
                guid=token, unzipDirectory=unzipped, modelIdentifier=identifier, instanceName=instance
            )
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            addLoggerProxy(ctypes.byref(callbacks))
            self._callbacks = callbacks
            self.fmu.instantiate(callbacks=callbacks)
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
            self.fmu.enterContinuousTimeMode()
        else:
            from fmpy.fmi3 import FMU3Model

            self.fmu = FMU3Model(
                guid=token, unzipDirectory=unzipped, modelIdentifier=identifier, instanceName=instance
            )
            self.fmu.instantiate(logMessage=self._log3)
            self.fmu.enterInitializationMode(startTime=0.0)
            self.fmu.exitInitializationMode()
            self.fmu.enterContinuousTimeMode()
        self.dof = sum(1 for name in self.vr if name.startswith("dtheta"))

    def _log2(self, env: object, name: bytes, status: int, category: bytes, message: bytes) -> None:
        self.messages.append(message.decode())

    def _log3(self, env: object, status: int, category: bytes, message: bytes) -> None:
        self.messages.append(message.decode())

    def set(self, values: dict[str, float]) -> None:
        refs = [self.vr[name] for name in values]
        if self.version == 2:
            self.fmu.setReal(refs, list(values.values()))
        else:
            self.fmu.setFloat64(refs, list(values.values()))

    def get(self, names: Sequence[str]) -> np.ndarray:
        refs = [self.vr[name] for name in names]
        values = self.fmu.getReal(refs) if self.version == 2 else self.fmu.getFloat64(refs)
        return np.array(values)

    def set_state(self, q: Sequence[float], qd: Sequence[float], u: float) -> None:
        values = {f"theta{i}": q[i] for i in range(self.dof)}
        values.update({f"dtheta{i}": qd[i] for i in range(self.dof)})
        values["u"] = u
        self.set(values)

    def derivatives(self) -> np.ndarray:
        n = 2 * self.dof
        out = (ctypes.c_double * n)()
        if self.version == 2:
            self.fmu.getDerivatives(out, n)
        else:
            self.fmu.getContinuousStateDerivatives(out, n)
        return np.array(out)

    def directional(
        self, unknowns: Sequence[str], knowns: Sequence[str], seed: Sequence[float]
    ) -> np.ndarray:
        u = [self.vr[n] for n in unknowns]
        k = [self.vr[n] for n in knowns]
        if self.version == 2:
            return np.array(self.fmu.getDirectionalDerivative(u, k, list(seed)))
        return np.array(self.fmu.getDirectionalDerivative(u, k, list(seed)))

    def adjoint(self, unknowns: Sequence[str], knowns: Sequence[str], seed: Sequence[float]) -> np.ndarray:
        u = [self.vr[n] for n in unknowns]
        k = [self.vr[n] for n in knowns]
        return np.array(self.fmu.getAdjointDerivative(u, k, list(seed), nSensitivity=len(k)))

    def reset(self) -> None:
        self.fmu.reset()
        if self.version == 2:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
            self.fmu.enterContinuousTimeMode()
        else:
            self.fmu.enterInitializationMode(startTime=0.0)
            self.fmu.exitInitializationMode()
            self.fmu.enterContinuousTimeMode()

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
