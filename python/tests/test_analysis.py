"""Analysis from Python: the derivatives of forward and inverse dynamics against central
differences in tangent coordinates, the tangent maps, linearize's JSON object, and static
equilibrium (docs/python.md, "Analysis")."""

from __future__ import annotations

import json
from typing import Callable

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES

EPS = np.finfo(float).eps
# Central differences: the step h = eps^(1/3) max(1, |x|) per entry (x the entry's value; 0 for a
# tangent coordinate, which is a deviation) balances the truncation error (h^2 f''' / 6) against
# round-off (eps |f| / h): both near eps^(2/3) ~ 4e-11 of the function's scale. The agreement
# asked is 1e-6 of the block's largest entry, with room for third derivatives a thousand times
# the function's scale.
CBRT_EPS = EPS ** (1.0 / 3.0)
RELATIVE = 1e-6


def step(x: float) -> float:
    return CBRT_EPS * max(1.0, abs(x))


def central(f: Callable[[np.ndarray], np.ndarray], x0: np.ndarray) -> np.ndarray:
    """The Jacobian of f at x0 by central differences, column by column (step rule above)."""
    columns = []
    for j in range(x0.size):
        h = step(x0[j])
        plus, minus = x0.copy(), x0.copy()
        plus[j] += h
        minus[j] -= h
        columns.append((f(plus) - f(minus)) / (plus[j] - minus[j]))
    return np.array(columns).T


def assert_close(actual: np.ndarray, expected: np.ndarray, what: str) -> None:
    assert actual.shape == expected.shape, what
    scale = max(np.abs(expected).max(), np.abs(actual).max(), 1e-300)
    error = np.abs(actual - expected).max() / scale
    assert error <= RELATIVE, f"{what}: differs by {error:.2e} of its largest entry {scale:.3e}"


def random_point(model: kanedyn.Model, rng: np.random.Generator):
    """A state away from any symmetry: the initial q turned by a random tangent deviation (up to
    0.5 rad per entry), random speeds up to 2, random inputs up to 3."""
    n = len(model.tangent_state_names) // 2
    q = model.retract(model.initial_joint_coordinates, rng.uniform(-0.5, 0.5, n))
    z = rng.uniform(-2.0, 2.0, n)
    u = rng.uniform(-3.0, 3.0, len(model.inputs))
    return q, z, u


def check_forward(model: kanedyn.Model, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q, z, u = random_point(model, rng)
    n = z.size
    dq, dz, du = model.forward_derivatives(q=q, z=z, u=u)
    assert dq.shape == (n, n) and dz.shape == (n, n) and du.shape == (n, len(model.inputs))
    # Positions are perturbed in tangent coordinates: q0 (+) dx by the exact exponential map.
    fd_q = central(lambda dx: model.forward(model.retract(q, dx), z, u), np.zeros(n))
    fd_z = central(lambda zz: model.forward(q, zz, u), z)
    assert_close(dq, fd_q, "d(z dot)/dq")
    assert_close(dz, fd_z, "d(z dot)/dz")
    if len(model.inputs):
        assert_close(du, central(lambda uu: model.forward(q, z, uu), u), "d(z dot)/du")


def test_forward_derivatives_of_the_urdf_arm_match_central_differences() -> None:
    arm = kanedyn.load(EXAMPLES / "urdf" / "arm.urdf")  # six revolute joints, damped; six inputs
    assert len(arm.inputs) == 6
    for seed in range(3):
        check_forward(arm, seed)


def test_forward_derivatives_of_free_bodies_match_central_differences() -> None:
    # Eight free bodies on bushings: every position entry a rotation vector or a translation.
    eight = kanedyn.load(EXAMPLES / "eight_body.yaml")
    assert set(eight.joint_types) == {"free"}
    for seed in range(2):
        check_forward(eight, 10 + seed)


def test_forward_derivatives_with_inputs_on_free_bodies() -> None:
    # A free body driven by a force at a point off its mass centre and a torque: du depends on
    # the orientation, and dq carries u's moment arm.
    model = kanedyn.load(
        {
            "format": "kanedyn-model/1",
            "gravity": [0, 0, -9.81],
            "bodies": [
                {"name": "base", "parent": "ground", "mass": 2.0, "inertia": [0.1, 0.2, 0.3]},
                {
                    "name": "arm",
                    "parent": "base",
                    "mass": 0.5,
                    "inertia": [0.01, 0.02, 0.025],
                    "com": [0.2, 0, 0],
                    "joint": {"type": "spherical", "at": [0, 0.1, 0]},
                },
            ],
            "inputs": [
                {"name": "thrust", "type": "force", "body": "base", "direction": [0, 0, 1], "point": [0.3, 0, 0]},
                {"name": "twist", "type": "torque", "body": "arm", "axis": [0, 1, 0], "reaction": True},
            ],
        }
    )
    check_forward(model, 21)


def test_inverse_derivatives_match_central_differences_and_the_forward_ones() -> None:
    arm = kanedyn.load(EXAMPLES / "urdf" / "arm.urdf")
    q, z, u = random_point(arm, np.random.default_rng(5))
    n = z.size
    zdot = np.random.default_rng(6).uniform(-1.0, 1.0, n)
    s = arm.state(q=q, z=z)
    dq, dz, du = arm.inverse_derivatives(s, zdot, u)
    Q = arm.inverse_dynamics
    assert_close(dq, central(lambda dx: Q(arm.state(q=arm.retract(q, dx), z=z), zdot, u), np.zeros(n)), "dQ/dq")
    assert_close(dz, central(lambda zz: Q(arm.state(q=q, z=zz), zdot, u), z), "dQ/dz")
    assert_close(du, central(lambda uu: Q(s, zdot, uu), u), "dQ/du")
    # The keyword form is the same call.
    for a, b in zip(arm.inverse_derivatives(q=q, z=z, zdot=zdot, u=u), (dq, dz, du)):
        np.testing.assert_array_equal(a, b)
    # At zdot = F(q, z, u), M d(zdot) + dQ = 0: the forward derivatives are -M^-1 dQ. Both
    # come from the same dual numbers, so they agree to the round-off of one solve with M
    # (condition number of the arm's M ~ 1e3): 1e-9 of the largest entry.
    at_rest = arm.forward(q, z, u)
    fq, fz, fu = arm.forward_derivatives(s, u)
    M = arm.mass_matrix(s)
    for forward_block, inverse_block in zip((fq, fz, fu), arm.inverse_derivatives(s, at_rest, u)):
        expected = -np.linalg.solve(M, inverse_block)
        assert np.abs(forward_block - expected).max() <= 1e-9 * np.abs(expected).max()


def test_retract_and_tangent_difference_undo_each_other() -> None:
    eight = kanedyn.load(EXAMPLES / "eight_body.yaml")
    rng = np.random.default_rng(3)
    q0 = eight.initial_joint_coordinates
    n = len(eight.tangent_state_names) // 2
    dx = rng.uniform(-1.0, 1.0, n)  # rotation vectors of norm below pi: the principal ones
    q = eight.retract(q0, dx)
    # Unit Euler parameters after the exact exponential map (the State check would refuse
    # anything off by more than 1e-6; asked here to round-off).
    for k in range(eight.N):
        assert abs(np.linalg.norm(q[7 * k : 7 * k + 4]) - 1.0) < 1e-14
    np.testing.assert_allclose(eight.tangent_difference(q0, q), dx, rtol=0, atol=1e-13)
    # A State is taken for q0 and q as well.
    np.testing.assert_allclose(eight.tangent_difference(eight.initial_state(), eight.state(q=q)), dx, rtol=0, atol=1e-13)
    with pytest.raises(ValueError, match="dx must have shape"):
        eight.retract(q0, dx[:-1])


def test_tangent_state_names_follow_the_spec() -> None:
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    assert cart.tangent_state_names == ["cart.j1", "pole.j1", "cart.jd1", "pole.jd1"]
    racket = kanedyn.load(EXAMPLES / "tennis_racket.yaml")
    r = [f"racket.r{i}" for i in (1, 2, 3)] + [f"racket.s{i}" for i in (1, 2, 3)]
    w = [f"racket.w{i}" for i in (1, 2, 3)] + [f"racket.sd{i}" for i in (1, 2, 3)]
    assert racket.tangent_state_names == r + w


SPEC_KEYS = ["n", "m", "state", "inputs", "q", "z", "u", "A", "B", "eigenvalues"]


def test_linearize_gives_the_spec_json_object() -> None:
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    lin = cart.linearize(cart.state(q=[0.1, 0.0], z=[0.0, 0.0]), u=[0.5])
    d = lin.as_dict()
    assert list(d) == SPEC_KEYS
    assert (d["n"], d["m"]) == (2, 1)
    assert d["state"] == ["cart.j1", "pole.j1", "cart.jd1", "pole.jd1"] and d["inputs"] == ["push"]
    assert d["q"] == [0.1, 0.0] and d["z"] == [0.0, 0.0] and d["u"] == [0.5]
    assert np.array(d["A"]).shape == (4, 4) and np.array(d["B"]).shape == (4, 1)
    assert np.array(d["eigenvalues"]).shape == (4, 2)
    # Plain Python numbers only, which JSON writes and reads back exactly (repr round-trips).
    assert json.loads(lin.to_json()) == d
    assert json.loads(json.dumps(d)) == d
    # The object's arrays are the dict's numbers.
    np.testing.assert_array_equal(np.array(d["A"]), lin.A)
    np.testing.assert_array_equal(np.array(d["B"]), lin.B)
    e = np.array(d["eigenvalues"])
    np.testing.assert_array_equal(e[:, 0] + 1j * e[:, 1], lin.eigenvalues)
    # A's lower rows are the forward derivatives at the point; its upper rows say that the
    # coordinates' rates are the speeds (no Euler parameters here); B's lower rows are du.
    dq, dz, du = cart.forward_derivatives(q=lin.q, z=lin.z, u=lin.u)
    np.testing.assert_array_equal(lin.A[2:], np.hstack([dq, dz]))
    np.testing.assert_array_equal(lin.A[:2], np.hstack([np.zeros((2, 2)), np.eye(2)]))
    np.testing.assert_array_equal(lin.B, np.vstack([np.zeros((2, 1)), du]))
    # Pushed and tilted, the cart-pole is not at rest: zdot is F there.
    # z dot there comes from the factored mass matrix and the bias forces: the forward
    # route's to round-off.
    np.testing.assert_allclose(lin.zdot, cart.forward(lin.q, lin.z, lin.u), rtol=0, atol=1e-12)
    assert lin.modes is None and not lin.periodic


def test_linearize_without_inputs_has_no_B_and_gives_modes() -> None:
    eight = kanedyn.load(EXAMPLES / "eight_body.yaml")
    lin = eight.linearize(modes=True)  # the initial state, which moves
    d = lin.as_dict()
    assert list(d) == [k for k in SPEC_KEYS if k != "B"] + ["modes"] and d["m"] == 0
    assert eight.linearize().as_dict().keys() == d.keys() - {"modes"}
    n = d["n"]
    assert n == 48 and len(d["state"]) == 96 and np.array(d["A"]).shape == (96, 96)
    assert json.loads(lin.to_json(indent=1)) == d
    # Each column of modes is an eigenvector of A for its eigenvalue, largest entry 1.
    assert lin.modes.shape == (96, 96) and lin.modes.dtype == np.complex128
    residual = lin.A @ lin.modes - lin.modes * lin.eigenvalues
    assert np.abs(residual).max() <= 1e-9 * np.abs(lin.A).max()
    np.testing.assert_allclose(np.abs(lin.modes).max(axis=0), 1.0, rtol=0, atol=1e-12)
    m = np.array(d["modes"])  # columns of [re, im] pairs
    np.testing.assert_array_equal(m[..., 0].T + 1j * m[..., 1].T, lin.modes)
    mode = lin.mode(0)
    assert list(mode) == lin.state and max(abs(v) for v in mode.values()) == pytest.approx(1.0)
    # The sort of the spec: decreasing real part, then decreasing imaginary part.
    e = lin.eigenvalues
    keys = list(zip(-e.real, -e.imag))
    assert keys == sorted(keys)


def test_linearize_at_the_pendulum_bottom_gives_its_frequency() -> None:
    # The pendulum of cart_pendulum.yaml on a hinge fixed to the ground: 0.5 kg, its mass centre
    # l = 0.3 m below the hinge, I = 0.0168 kg m^2 about the centre. Hanging, it swings at
    # w = sqrt(m g l / (I + m l^2)): eigenvalues +-i w (round-off of a 2 x 2 problem: 1e-12).
    pendulum = kanedyn.load(
        {
            "format": "kanedyn-model/1",
            "gravity": [0, 0, -9.81],
            "bodies": [
                {
                    "name": "pendulum",
                    "parent": "ground",
                    "mass": 0.5,
                    "inertia": [0.0168, 0.0168, 0.0002],
                    "com": [0, 0, -0.3],
                    "joint": {"type": "revolute", "axis": [0, 1, 0]},
                }
            ],
        }
    )
    lin = pendulum.linearize(q=[0.0], z=[0.0])
    w = np.sqrt(0.5 * 9.81 * 0.3 / (0.0168 + 0.5 * 0.3**2))
    np.testing.assert_allclose(lin.eigenvalues, [1j * w, -1j * w], rtol=1e-12, atol=1e-12 * w)
    assert "neutral" in str(lin) and f"{w / (2 * np.pi):.4g} Hz" in str(lin) and "periodic" not in str(lin)
    # The cart-pendulum at rest, hanging, is an undamped oscillator too: every eigenvalue on the
    # imaginary axis (to the round-off of a 4 x 4 eigenproblem).
    model = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    e = model.linearize(q=[0.0, 0.0], z=[0.0, 0.0]).eigenvalues
    assert np.abs(e.real).max() <= 1e-12 * np.abs(e).max()


def test_linearize_checks_its_arguments() -> None:
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    with pytest.raises(ValueError, match=r"u must have shape \(m,\) = \(1,\).*push"):
        cart.linearize(u=[1.0, 2.0])
    with pytest.raises(ValueError, match="q must have shape"):
        cart.linearize(q=[0.0])
    with pytest.raises(TypeError, match="modes"):
        cart.linearize(modes="yes")
    with pytest.raises(ValueError, match="not both"):
        cart.linearize(cart.initial_state(), q=[0.0, 0.0])
    with pytest.raises(TypeError, match="needs zdot"):
        cart.inverse_derivatives(cart.initial_state())
    with pytest.raises(ValueError, match="has no modes"):
        cart.linearize().mode(0)
    # Finite but absurd speeds overflow the derivatives: refused, saying so.
    with pytest.raises(ValueError, match="derivatives at this state are not finite"):
        cart.linearize(z=[1e200, 1e200])


def test_equilibrium_of_the_hanging_figure() -> None:
    # The eight-body figure hangs on its bushings: Newton from the file's pose finds where
    # gravity and the bushings balance, and nothing accelerates there.
    eight = kanedyn.load(EXAMPLES / "eight_body.yaml")
    rest = eight.equilibrium()
    assert rest.converged and bool(rest), rest.message
    assert rest.residual_norm <= rest.tolerance * rest.scale
    assert rest.unrestrained == [] and rest.free == eight.tangent_state_names[:48]
    zdot = eight.forward(rest.q, np.zeros(48))
    # The generalized forces are below 1e-10 of the force scale (the figure's weight, ~700 N):
    # accelerations of that force over the lightest body's mass and inertia, far below 1e-6.
    assert np.abs(zdot).max() < 1e-6
    # Damped bushings: the rest pose is stable, every eigenvalue in the left half-plane.
    assert rest.eigenvalues is not None and rest.eigenvalues.real.max() < 0
    np.testing.assert_array_equal(rest.linearization.z, np.zeros(48))


def test_equilibrium_with_some_coordinates_free() -> None:
    # The cart-pendulum: cart on a spring (rest at 0), the pendulum hanging at angle 0. Free only
    # the pendulum (by its coordinate's name): the cart keeps its 0.25 m and the pendulum
    # hangs straight down, angle 0 (the cart's position does not tilt it).
    model = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    start = model.state(q=[0.25, 0.5], z=[0.0, 0.0])
    rest = model.equilibrium(free=["pendulum.j1"], state=start)
    assert rest.converged and rest.free == ["pendulum.j1"] and rest.residual.shape == (1,)
    assert rest.q[0] == 0.25
    assert abs(rest.q[1]) < 1e-10
    # With the cart held, the pendulum alone swings about its hinge: 0.5 kg, mass centre
    # l = 0.3 m below, I = 0.0168 kg m^2 about it, at w = sqrt(m g l / (I + m l^2)).
    held = rest.linearization
    assert held.state == ["pendulum.j1", "pendulum.jd1"] and held.A.shape == (2, 2) and held.n == 1
    w = np.sqrt(0.5 * 9.81 * 0.3 / (0.0168 + 0.5 * 0.3**2))
    np.testing.assert_allclose(rest.eigenvalues, [1j * w, -1j * w], rtol=1e-12, atol=1e-12 * w)
    # Freeing the body frees all of its coordinates; both: the spring pulls the cart to 0.
    both = model.equilibrium(free=["cart", "pendulum"], state=start)
    assert both.converged and both.free == ["cart.j1", "pendulum.j1"]
    np.testing.assert_allclose(both.q, [0.0, 0.0], rtol=0, atol=1e-10)
    # Every coordinate named free is the whole model's linearization at the rest pose (by the
    # inverse derivatives here, the forward ones there: round-off apart).
    whole = model.linearize(q=both.q, z=[0.0, 0.0])
    assert both.linearization.state == whole.state
    assert np.abs(both.linearization.A - whole.A).max() <= 1e-12 * np.abs(whole.A).max()
    # At the hanging pose: oscillations only (no damping in this model).
    assert np.abs(both.eigenvalues.real).max() <= 1e-12 * np.abs(both.eigenvalues).max()


def test_equilibrium_with_inputs_is_where_they_balance_gravity() -> None:
    # The URDF arm with its joint torques held at u = g(q*), the generalized gravity at q*
    # (Model.gravity_forces, the torques that hold the arm there): from 0.05 rad off on every
    # joint Newton comes back to q*. The shoulder pan turns about the vertical and the last
    # wrist joint about the tool's axis here, so gravity restrains neither: they keep their
    # start and are reported. The others land on q* to the residual's tolerance (3e-10 N m)
    # over the gravity stiffness (order 1 N m / rad): asserted 1e-8 rad.
    arm = kanedyn.load(EXAMPLES / "urdf" / "arm.urdf")
    target = np.array([0.4, -0.9, 1.3, -0.6, 0.5, 0.3])
    u = arm.gravity_forces(arm.state(q=target))
    rest = arm.equilibrium(u=u, state=arm.state(q=target + 0.05))
    assert rest.converged, rest.message
    assert rest.unrestrained == ["shoulder_link.j1", "wrist_3_link.j1"]
    np.testing.assert_array_equal(rest.u, u)
    np.testing.assert_allclose(rest.q[1:5], target[1:5], rtol=0, atol=1e-8)
    np.testing.assert_allclose(rest.q[[0, 5]], target[[0, 5]] + 0.05, rtol=0, atol=1e-12)
    # Held by constant torques, not springs: a rest pose, but not a stable one.
    assert rest.eigenvalues.real.max() > 0.1


def test_linearize_of_a_spinning_free_body_is_periodic() -> None:
    racket = kanedyn.load(EXAMPLES / "tennis_racket.yaml")  # spinning at 6 rad/s about y
    lin = racket.linearize()
    assert lin.periodic and "periodic" in lin.summary()
    assert not racket.linearize(q=racket.initial_joint_coordinates, z=np.zeros(6)).periodic
    # The rotation vector's rate at the spin w0: dr/dt = dw - w0 x r, so A's top-left block is
    # -[w0~] (the spec, "Linearization output").
    w0 = racket.initial_joint_speeds[:3]
    skew = np.array([[0, -w0[2], w0[1]], [w0[2], 0, -w0[0]], [-w0[1], w0[0], 0]])
    np.testing.assert_array_equal(lin.A[:3, :3], -skew)
    np.testing.assert_array_equal(lin.A[:6, 6:], np.eye(6))


def test_equilibrium_that_cannot_converge_returns_and_says_why() -> None:
    # A free body under gravity with nothing holding it: no rest pose. The result says so
    # instead of raising, with the coordinates that nothing restrains.
    model = kanedyn.load(
        {
            "format": "kanedyn-model/1",
            "gravity": [0, 0, -9.81],
            "bodies": [{"name": "ball", "parent": "ground", "mass": 1.0, "inertia": [0.1, 0.1, 0.1]}],
        }
    )
    rest = model.equilibrium(max_iterations=5)
    assert not rest.converged and not bool(rest)
    assert "did not converge" in rest.message
    assert rest.residual_norm == pytest.approx(9.81, rel=1e-12)  # its weight, on ball.s3
    assert "ball.s3" in rest.unrestrained
    assert rest.eigenvalues is None and rest.linearization is None


def test_equilibrium_refuses_a_bad_free_name_with_the_closest() -> None:
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    with pytest.raises(ValueError, match=r"free: no body or coordinate named 'pole\.j2' \(did you mean 'pole\.j1'\?\)"):
        cart.equilibrium(free=["pole.j2"])
    with pytest.raises(ValueError, match=r"no body or coordinate named 'pol' \(did you mean 'pole'\?\)"):
        cart.equilibrium(free=["cart", "pol"])
    with pytest.raises(ValueError, match=r"'pole\.jd1' is a speed; free takes coordinates \('pole\.j1'\)"):
        cart.equilibrium(free="pole.jd1")
    with pytest.raises(ValueError, match="free is empty"):
        cart.equilibrium(free=[])
    with pytest.raises(ValueError, match=r"free: index 2 is not in 0\.\.1"):
        cart.equilibrium(free=[2])
    with pytest.raises(ValueError, match="tolerance"):
        cart.equilibrium(tolerance=0.0)
    with pytest.raises(ValueError, match="max_iterations"):
        cart.equilibrium(max_iterations=-1)


def test_linearize_gives_the_object_of_the_tool() -> None:
    # `kanedyn linearize MODEL --json` and Model.linearize() at the same default operating point
    # (the initial state, zero inputs) call the same library function: the same numbers, bit
    # for bit once read back (both write doubles that round-trip). Skipped by a tool built
    # without the command.
    from conftest import run_tool

    for name in ("cart_pole.yaml", "tennis_racket.yaml"):
        done = run_tool(["linearize", EXAMPLES / name, "--json"])
        if "unknown command 'linearize'" in done.stderr:
            pytest.skip("this build's tool has no linearize command")
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout) == kanedyn.load(EXAMPLES / name).linearize().as_dict()


def test_derivatives_from_several_threads_equal_the_serial_ones() -> None:
    # Each call takes a workspace (its own Derivatives) from the model's pool, and models of 32
    # bodies or more compute without the GIL: four threads on one 64-body model at once give
    # the serial results bit for bit.
    import threading

    chain = kanedyn.load(EXAMPLES / "chain64.yaml")
    rng = np.random.default_rng(8)
    n = len(chain.tangent_state_names) // 2
    points = [(chain.retract(chain.initial_joint_coordinates, rng.uniform(-0.3, 0.3, n)), rng.uniform(-1, 1, n)) for _ in range(8)]
    serial = [chain.forward_derivatives(q=q, z=z) for q, z in points]
    failures = []

    def worker(offset: int) -> None:
        for i in range(len(points)):
            k = (i + offset) % len(points)
            got = chain.forward_derivatives(q=points[k][0], z=points[k][1])
            if any(a.tobytes() != b.tobytes() for a, b in zip(got, serial[k])):
                failures.append(k)

    threads = [threading.Thread(target=worker, args=(t,)) for t in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert failures == []


def test_summary_counts_the_state_and_writes_one_in_the_singular() -> None:
    # The bicycle's state is its independent coordinates then its 3 independent speeds: A is
    # (10, 10), counted from the matrix, not from 2n. The cart-pole has one input.
    bicycle = kanedyn.load(EXAMPLES / "bicycle.yaml").linearize()
    assert bicycle.A.shape == (10, 10) and bicycle.n == 3
    assert bicycle.summary().splitlines()[0] == "linearized: n = 3 speeds, m = 0 inputs, 10 states"
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml").linearize()
    assert cart.A.shape == (4, 4) and cart.m == 1
    assert cart.summary().splitlines()[0] == "linearized: n = 2 speeds, m = 1 input, 4 states"
    pendulum = kanedyn.load(EXAMPLES / "pendulum.yaml").linearize()
    assert pendulum.summary().splitlines()[0] == "linearized: n = 1 speed, m = 0 inputs, 2 states"
