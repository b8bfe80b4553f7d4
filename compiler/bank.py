"""Jitted functions by name: the artifact's exported kernels when it has them, else traced.

Every JAX function the compiler builds for a run (condition kernels, projectors, distance
gradients, forward kinematics) is obtained as ``bank.function(key, build, spec)``:

* ``key`` names the function stably across processes (``"proj/action/pickup"``, ``"fk/frames"``);
* ``build()`` returns the Python function to trace; it is called only when the bank has no
  exported kernel for ``key`` (so a run from an artifact lowers no IR and traces nothing);
* ``spec`` gives the argument shapes and dtypes, ``"b"`` marking the batch dimension, which is
  exported symbolically: one exported kernel serves every batch size (XLA compiles each concrete
  size on its first call, and the persistent compilation cache keeps that across processes).

``tmpc compile`` (and the run cache) registers every function a run needs, then
:meth:`KernelBank.export` serializes them with ``jax.export``; :meth:`KernelBank.load` reads them
back. Functions that call the host (untraceable Lua predicates) cannot be serialized: they are
skipped with a reason, and traced from the embedded sources when used. ``stats`` counts what was
deserialized and what was traced, so a test can assert that a run from the artifact cache traced
nothing.
"""

from __future__ import annotations

import threading
import time
import warnings
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from tmpc.compiler.jaxcfg import configured, trim_heap
from tmpc.compiler.robot import Frames

#: one argument: (shape with "b" for the batch dimension, dtype name)
ArgSpec = tuple[tuple, str]
F64, I64 = "float64", "int64"


@dataclass
class BankStats:
    """What the bank did: kernels deserialized, traced (built from IR), and the keys traced."""

    deserialized: int = 0
    traced: int = 0
    traced_keys: list[str] = field(default_factory=list)
    seconds_deserialize: float = 0.0


class KernelBank:
    """Functions by key (see the module docstring). ``exported``: key -> serialized kernel
    (``jax.export`` bytes) from an artifact; empty for a program compiled from sources."""

    def __init__(self, exported: dict[str, bytes] | None = None, source: str | None = None):
        self._exported = dict(exported or {})
        self._source = source            # where the exported kernels came from (for warnings)
        self._functions: dict[str, BankFunction] = {}
        #: keys the artifact said it could not serialize (host callbacks): traced, no warning
        self._skipped_ok: frozenset = frozenset()
        self.stats = BankStats()
        self._lock = threading.Lock()
        #: serialized kernel -> its jitted call: keys with byte-identical kernels (tmit-star's
        #: shelves: pick-lower, pick-top and pick-upper) share one executable, loaded once
        self._loaded: dict[bytes, Callable] = {}

    def function(self, key: str, build: Callable[[], Callable], spec: Sequence[ArgSpec],
                 unexportable: Callable[[], str | None] | None = None) -> "BankFunction":
        """The jitted function ``key`` (built once per bank). ``unexportable()``, asked only
        when exporting, gives the reason a function cannot be serialized (None: it can)."""
        fn = self._functions.get(key)
        if fn is None:
            fn = self._functions[key] = BankFunction(self, key, build, tuple(spec))
            fn.unexportable = unexportable
        return fn

    @property
    def keys(self) -> list[str]:
        """Keys of every function registered so far."""
        return sorted(self._functions)

    def has_exported(self, key: str) -> bool:
        return key in self._exported

    def exported(self, key: str) -> bytes | None:
        """The serialized kernel of ``key`` (None: none exported): equal bytes, one kernel."""
        return self._exported.get(key)

    def _resolve(self, fn: "BankFunction") -> Callable:
        jax = configured()
        data = self._exported.get(fn.key)
        if data is not None:
            same = self._loaded.get(data)
            if same is not None:
                return same
            from jax import export  # the export machinery, only when kernels are loaded
            t = time.perf_counter()
            exp = export.deserialize(bytearray(data))
            self.stats.deserialized += 1
            self.stats.seconds_deserialize += time.perf_counter() - t
            jitted = self._loaded[data] = _without_lapack(jax.jit(exp.call)) \
                if b"lapack" not in data else jax.jit(exp.call)
            return jitted
        if self._source is not None and fn.key not in self._skipped_ok:
            warnings.warn(f"kernel {fn.key} is not in {self._source}: traced from its sources",
                          stacklevel=3)
        self.stats.traced += 1
        self.stats.traced_keys.append(fn.key)
        return jax.jit(fn.python())

    # ---- serialization -----------------------------------------------------------------------
    def export(self, cached: Callable[[str, tuple, Callable[[], bytes]], bytes] | None = None,
               progress: Callable[[int, int, str], None] | None = None
               ) -> tuple[dict[str, bytes], dict[str, str]]:
        """(key -> serialized kernel, key -> why it was skipped) for every registered function.
        ``cached(key, spec, make)`` may return stored bytes instead of calling ``make()``;
        ``progress(i, n, key)`` is called before the i-th (1-based) of the n keys."""
        jax = configured()
        out, skipped = {}, {}
        _register_pytrees()
        keys = self.keys
        for i, key in enumerate(keys, 1):
            if progress is not None:
                progress(i, len(keys), key)
            fn = self._functions[key]
            if key in self._exported:
                out[key] = self._exported[key]
                continue
            reason = fn.unexportable() if fn.unexportable is not None else None
            if reason is not None:
                skipped[key] = reason
                continue
            make = lambda fn=fn: _serialize(jax, fn)        # noqa: E731
            try:
                out[key] = cached(key, fn.spec, make) if cached is not None else make()
            except Exception as exc:     # noqa: BLE001 - host callbacks cannot be exported
                skipped[key] = f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}"
        # from now on this bank runs the exported kernels too: nothing is traced twice
        self._exported.update(out)
        self._skipped_ok = self._skipped_ok | frozenset(skipped)
        return out, skipped

    @classmethod
    def load(cls, exported: dict[str, bytes], skipped: Sequence[str], source: str) -> "KernelBank":
        _register_pytrees()
        bank = cls(exported, source)
        bank._skipped_ok = frozenset(skipped)
        return bank


class BankFunction:
    """A bank entry: call it like the jitted function it stands for."""

    __slots__ = ("bank", "key", "spec", "unexportable", "_build", "_python", "_jitted",
                 "_sizes", "_batch_at", "__weakref__")

    def __init__(self, bank: KernelBank, key: str, build: Callable[[], Callable], spec):
        self.bank, self.key, self.spec = bank, key, spec
        self._build, self._python, self._jitted = build, None, None
        self.unexportable = None
        self._sizes: dict[int, BankFunction] = {}
        self._batch_at = next(((i, shape.index("b")) for i, (shape, _) in enumerate(spec)
                               if "b" in shape), None)

    def specialize(self, sizes) -> "BankFunction":
        """Also export (and call) this function at these concrete batch sizes: a call with one
        of them runs ``key@size``, which XLA loads without refining symbolic shapes (refining
        them costs time per kernel and call site); other sizes run the symbolic kernel."""
        if self._batch_at is None:
            return self
        for n in sizes:
            if n not in self._sizes:
                spec = tuple((tuple(n if d == "b" else d for d in shape), dt)
                             for shape, dt in self.spec)
                # one Python function (one lowering) for every size
                self._sizes[int(n)] = self.bank.function(f"{self.key}@{n}", self.python, spec,
                                                         self.unexportable)
        return self

    def exported(self, batch: int) -> bytes | None:
        """The serialized kernel a call with ``batch`` states runs (None: none exported)."""
        return self.bank.exported(self._sizes.get(batch, self).key)

    def python(self) -> Callable:
        """The traceable Python function (built on first use: this lowers IR)."""
        if self._python is None:
            self._python = self._build()
        return self._python

    def __call__(self, *args):
        if self._sizes:
            i, j = self._batch_at
            sub = self._sizes.get(args[i].shape[j])
            # an artifact without this size (made without the runtime's sizes) runs the symbolic
            # kernel it has rather than tracing
            if sub is not None and (self.bank._source is None or
                                    self.bank.has_exported(sub.key)):
                return sub(*args)
        fresh = self._jitted is None
        if fresh:
            with self.bank._lock:            # warm-up threads: deserialize and count once
                if self._jitted is None:
                    self._jitted = self.bank._resolve(self)
        out = self._jitted(*args)
        if fresh:
            trim_heap()                      # the compile's (or cache read's) freed buffers
        return out


_LOWERING = threading.local()
_LAPACK_HOOK: list = []


def _without_lapack(jitted: Callable) -> Callable:
    """``jitted`` (an exported kernel's call) lowered without JAX's LAPACK set-up.

    Lowering any exported kernel for the CPU first initialises JAX's LAPACK bindings, which
    imports scipy.linalg for its function pointers, a noticeable part of every run's setup, for
    kernels that call no LAPACK routine (a kernel that does names ``lapack_...`` custom calls in
    its serialized module, and the bank leaves it alone). The set-up is skipped only while this
    thread lowers such a kernel; anything else still gets it. If JAX moves the hook, nothing is
    skipped."""
    if not _LAPACK_HOOK:
        try:
            from jax._src.export import _export
            original = _export._ensure_backends_initialized
        except (ImportError, AttributeError):
            original = None
        if original is not None:
            def ensure(platforms):
                if not getattr(_LOWERING, "no_lapack", False):
                    original(platforms)
            _export._ensure_backends_initialized = ensure
        _LAPACK_HOOK.append(original)
    if _LAPACK_HOOK[0] is None:
        return jitted

    def call(*args):
        _LOWERING.no_lapack = True
        try:
            return jitted(*args)
        finally:
            _LOWERING.no_lapack = False
    return call


def _serialize(jax, fn: BankFunction) -> bytes:
    """``fn`` exported. Its operations' source locations name tmpc's own frame only, by file
    name: with the full traceback and the path, the bytes depended on where tmpc is installed
    and on the caller (a script, the CLI, pytest), and so did the artifact."""
    from jax import export
    from jax._src import config
    with config.include_full_tracebacks_in_locations(False), \
            config.hlo_source_file_canonicalization_regex(r".*/"):
        return bytes(export.export(jax.jit(fn.python()))(*_shape_structs(jax, fn.spec))
                     .serialize())


def _shape_structs(jax, spec: Sequence[ArgSpec]):
    from jax import export
    (b,) = export.symbolic_shape("b")
    return [jax.ShapeDtypeStruct(tuple(b if d == "b" else int(d) for d in shape), np.dtype(dt))
            for shape, dt in spec]


_REGISTERED = False


def _register_pytrees() -> None:
    """The NamedTuples kernels return, registered once for jax.export's serialization."""
    global _REGISTERED
    if _REGISTERED:
        return
    configured()
    from jax import export
    export.register_namedtuple_serialization(Frames, serialized_name="tmpc.Frames")
    _REGISTERED = True
