import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from motionlab.representation import (
    axis_angle_to_quat,
    cont6d_to_matrix,
    cont6d_to_quat,
    euler_to_quat,
    matrix_to_quat,
    qbetween,
    qinv,
    qmul,
    qnormalize,
    qrot,
    quat_to_cont6d,
    quat_to_matrix,
    slerp,
)

quats = arrays(np.float64, (8, 4), elements=st.floats(-1, 1)).filter(lambda q: (np.linalg.norm(q, axis=-1) > 0.1).all())
vecs = arrays(np.float64, (8, 3), elements=st.floats(-2, 2))


@settings(max_examples=40, deadline=None)
@given(quats, vecs)
def test_qrot_matches_matrix_and_preserves_norm(q, v):
    q = qnormalize(q)
    rotated = qrot(q, v)
    assert np.allclose(rotated, np.einsum("nij,nj->ni", quat_to_matrix(q), v), atol=1e-9)
    assert np.allclose(np.linalg.norm(rotated, axis=-1), np.linalg.norm(v, axis=-1), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(quats, quats, vecs)
def test_qmul_composes_rotations_and_qinv_undoes(a, b, v):
    a, b = qnormalize(a), qnormalize(b)
    assert np.allclose(qrot(qmul(a, b), v), qrot(a, qrot(b, v)), atol=1e-9)
    assert np.allclose(qrot(qinv(a), qrot(a, v)), v, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(quats)
def test_matrix_and_6d_round_trips(q):
    q = qnormalize(q)
    back = matrix_to_quat(quat_to_matrix(q))
    assert (back[:, 0] >= 0).all()
    assert np.allclose(np.abs((back * q).sum(-1)), 1.0, atol=1e-9)  # q and -q are the same rotation
    assert np.allclose(cont6d_to_matrix(quat_to_cont6d(q)), quat_to_matrix(q), atol=1e-9)
    assert np.allclose(np.abs((cont6d_to_quat(quat_to_cont6d(q)) * q).sum(-1)), 1.0, atol=1e-9)


def test_6d_is_first_two_matrix_columns():
    q = qnormalize(np.array([0.3, -0.2, 0.9, 0.1]))
    m = quat_to_matrix(q)
    assert np.allclose(quat_to_cont6d(q), np.concatenate([m[:, 0], m[:, 1]]))


@settings(max_examples=40, deadline=None)
@given(vecs, vecs)
def test_qbetween_rotates_direction_onto_direction(a, b):
    ok = (np.linalg.norm(a, axis=-1) > 1e-3) & (np.linalg.norm(b, axis=-1) > 1e-3)
    a, b = a[ok], b[ok]
    q = qbetween(a, b)
    unit = lambda x: x / np.linalg.norm(x, axis=-1, keepdims=True)  # noqa: E731
    assert np.allclose(unit(qrot(q, a)), unit(b), atol=1e-6)


def test_qbetween_opposite_vectors_is_a_half_turn():
    q = qbetween(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert np.allclose(qrot(q, np.array([[0.0, 0.0, 1.0]])), [[0.0, 0.0, -1.0]], atol=1e-9)


def test_torch_in_torch_out_and_numpy_in_numpy_out():
    q = torch.tensor([[1.0, 0.0, 0.0, 0.0]])
    v = torch.tensor([[1.0, 2.0, 3.0]])
    out = qrot(q, v)
    assert isinstance(out, torch.Tensor) and out.dtype == torch.float32
    assert isinstance(qrot(q.numpy(), v.numpy()), np.ndarray)


def test_torch_path_keeps_gradients():
    angle = torch.tensor([0.3], requires_grad=True)
    q = torch.cat([torch.cos(angle / 2), torch.zeros(1), torch.sin(angle / 2), torch.zeros(1)])
    qrot(q, torch.tensor([1.0, 0.0, 0.0])).sum().backward()
    assert angle.grad is not None and torch.isfinite(angle.grad).all()


def test_euler_intrinsic_order():
    # Intrinsic ZXY: rotate about Z, then about the new X, then about the new Y: R = Rz @ Rx @ Ry.
    ang = np.array([30.0, 45.0, 60.0])
    axes = {"Z": [0.0, 0, 1], "X": [1.0, 0, 0], "Y": [0.0, 1, 0]}
    rz, rx, ry = (
        quat_to_matrix(axis_angle_to_quat(np.array(axes[k]), np.deg2rad(np.array(a)))) for k, a in zip("ZXY", ang)
    )
    assert np.allclose(quat_to_matrix(euler_to_quat(ang, "ZXY")), rz @ rx @ ry, atol=1e-9)
    with pytest.raises(ValueError, match="permutation"):
        euler_to_quat(ang, "XXY")


def test_slerp_endpoints_and_midpoint():
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    q1 = qnormalize(np.array([np.cos(0.5), 0.0, np.sin(0.5), 0.0]))  # 1 rad about y
    assert np.allclose(slerp(q0, q1, np.array(0.0)), q0)
    assert np.allclose(slerp(q0, q1, np.array(1.0)), q1)
    mid = slerp(q0, q1, np.array(0.5))
    assert np.allclose(mid, [np.cos(0.25), 0.0, np.sin(0.25), 0.0], atol=1e-9)
