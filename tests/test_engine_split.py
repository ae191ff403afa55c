"""The two kinds of compiled code (issue 41): integrators compiled once per method and layout,
compositions compiled per experiment and called through the addresses of their C entry
points."""

from __future__ import annotations

import numba
import numpy as np

from hgo.engine import codegen
from hgo.engine.jit import _call_void, _data_pointer
from hgo.engine.simulate import SolverSettings, no_noise, simulate
from hgo.engine.system import System
from hgo.observers.triangular import triangular_hgo
from hgo.plants.sp_linear import sp_linear_plant


def test_a_c_entry_point_is_called_through_its_address_with_the_arrays_data() -> None:
    """What the integrators rely on (numba ``cfunc`` and the ``call_void`` intrinsic, not
    numba's experimental first-class function types): a cfunc taking (float64, float64*,
    float64*) called from compiled code at its address writes through the pointers into
    the caller's arrays."""

    @numba.cfunc("void(float64, CPointer(float64), CPointer(float64))")
    def scale(t, x_ptr, out_ptr):
        x = numba.carray(x_ptr, 2)
        out = numba.carray(out_ptr, 2)
        out[0] = t * x[0]
        out[1] = t * x[1] + 1.0

    @numba.njit
    def call(address, t, x, out):
        _call_void(address, t, (_data_pointer(x), _data_pointer(out)))

    out = np.zeros(2)
    call(np.int64(scale.address), 3.0, np.array([2.0, -1.0]), out)
    assert out.tolist() == [6.0, -2.0]


def _system(law: str) -> System:
    plant = sp_linear_plant(nu1=3.0, nu2=0.0, x0=(0, 0))
    return System(plant, [triangular_hgo("o", K=[2, 2], xhat0=[3.0, 3.0], r0=1, law=law,
                                         p1=4 / 3, p2=1.5, b=0.28, M=[[3.0, 0], [0, 0]])])


def test_compositions_of_one_layout_share_one_compiled_integrator() -> None:
    """Two compositions of the same sizes (Sanfelice & Praly's observer with two gain laws:
    other constants, another composition text) run on one integrator module with one
    compiled ``integrate``; each run equals the pure-Python kernel's to 1e-12 (DOPRI5,
    10 s, rtol 1e-8): the composition each one calls is its own."""
    solver = SolverSettings(t_end=10.0, dt_out=0.5, method="dopri5")
    kernels, runs = [], []
    for law in ("sign_indefinite", "dead_zone"):
        system = _system(law)
        runs.append(simulate(system, solver, no_noise(1)))
        kernels.append(codegen.load_kernel(system, method="dopri5", noisy=False))
        python = codegen.load_kernel(system, compiled=False, method="dopri5", noisy=False)
        z, d, P = system.z0(), system.d0(), system.params()
        n_out = 21
        rec = [np.zeros((n_out, k)) for k in (system.nz, system.nd, 1, 1, 0, system.nxh)]
        python.function("integrate")(z, d, P, np.zeros((1, 1)), np.inf, np.zeros(0), 10.0,
                                     0.5, 0.01, 1e-8, 1e-10, 0.0, 0.0, 1e6, 2.5,
                                     np.zeros(n_out), *rec, np.zeros(system.n_acc()),
                                     np.zeros((0, 0)), np.array([0, 10**9, 0]))
        np.testing.assert_allclose(runs[-1].z, rec[0], rtol=1e-12, atol=1e-12)
    first, second = kernels
    assert first.integrator is second.integrator
    assert first.composition is not second.composition
    assert len(first.integrator.integrate.signatures) == 1
    assert np.abs(runs[0].z - runs[1].z).max() > 1e-3  # the two laws differ


def test_an_announced_cfunc_compile_is_a_numba_compile_event() -> None:
    """A cfunc compiled through ``codegen._announced`` (as every entry point of a composition
    is) is announced as numba announces a dispatcher (``numba:compile``),
    which run.json's compile seconds and the compile progress bar listen to: without it a
    new composition's compile counted as simulation time (measured: sp_fig1 0.61 s compile
    + 1.16 s 'simulate' before, 1.38 s + 0.59 s after)."""
    from numba.core import event
    from numba.core.ccallback import CFunc
    from numba.core.sigutils import normalize_signature

    def double(t, x_ptr):
        x = numba.carray(x_ptr, 1)
        x[0] = 2.0 * t

    cfunc = CFunc(double, normalize_signature("void(float64, CPointer(float64))"),
                  locals={}, options={})
    cfunc._compile_uncached = codegen._announced(cfunc)
    recorder = event.RecordingListener()
    with event.install_listener("numba:compile", recorder):
        cfunc.compile()
    starts = [ev.data["dispatcher"] for _, ev in recorder.buffer if ev.is_start]
    # the cfunc's compile, once and outermost (numba's own compile of carray's
    # implementation nests in it in a process that has not compiled that yet)
    assert starts[0] is cfunc and starts.count(cfunc) == 1
    out = np.zeros(1)
    call = numba.njit(lambda a, t, x: _call_void(a, t, (_data_pointer(x),)))
    call(np.int64(cfunc.address), 1.5, out)
    assert out[0] == 3.0


def _driven_f(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -x[0] + u[0]


def _driven_h(t, x, p, y):
    y[0] = x[0]


def test_one_integrator_serves_plants_with_and_without_inputs() -> None:
    """Sanfelice & Praly's plant (no input) and a driven oscillator (one input from an
    open-loop controller, so a longer work vector), each with the same observer: one
    integrator text (one cache entry, one compile) for the two compositions, which
    differ. The integrator is not specialised on the number of inputs nor on the work
    vector (the composition's own scratch)."""
    from hgo.controllers.open_loop import open_loop_controller
    from hgo.core.components import Params, Plant

    driven = Plant(name="driven", state_names=["x1", "x2"], output_names=["y"],
                   input_names=["u"], x0=np.zeros(2), p=Params(), f=_driven_f, h=_driven_h)
    plain = _system("sign_indefinite")
    forced = System(driven, plain.observers, open_loop_controller())
    for method in ("rk4", "dopri5", "dop853"):
        assert codegen.integrator_source(plain, method) == codegen.integrator_source(forced,
                                                                                    method)
    assert codegen.composition_source(plain)[0] != codegen.composition_source(forced)[0]
