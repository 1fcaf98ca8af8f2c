"""Helpers of the robot-file tests: example-robot-data's URDFs and Pinocchio's FK of them."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pytest


def robots_dir() -> Path:
    """example-robot-data's ``robots`` folder, located through the installed distribution."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.fail("example-robot-data is a test extra: pip install -e '.[test]'")
    for f in dist.files or []:
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts and str(f).endswith(".urdf"):
            p = Path(dist.locate_file(f))
            while p.name != "robots":
                p = p.parent
            return p
    pytest.fail("example-robot-data ships no robots/ folder")


def urdf_mimics(path: Path) -> dict[str, tuple[str, float, float]]:
    """{joint: (master, multiplier, offset)} of the file's moving ``<mimic>`` joints, read with
    the standard library's XML parser (independent of mechkin's importer)."""
    import xml.etree.ElementTree as ET

    out = {}
    for j in ET.parse(path).getroot().iter("joint"):
        m = j.find("mimic")
        if m is not None and j.get("type") != "fixed":
            out[j.get("name")] = (m.get("joint"), float(m.get("multiplier", 1.0)),
                                  float(m.get("offset", 0.0)))
    return out


def pin_model(path: Path):
    """Pinocchio's model with its own mimic joints; where Pinocchio refuses them (Talos: a
    master that is not an ancestor) the plain model, its mimic joints then set by the test from
    the XML (:func:`pin_q`)."""
    pin = pytest.importorskip("pinocchio")
    try:
        model = pin.buildModelFromUrdf(str(path), mimic=True)
        model.mimic_from_xml = {}
    except (ValueError, TypeError):  # (TypeError: a Pinocchio without mimic support)
        model = pin.buildModelFromUrdf(str(path))
        model.mimic_from_xml = urdf_mimics(path)
    return pin, model, model.createData()


def pin_q(model, mech, q: np.ndarray) -> np.ndarray:
    """mechkin's joint vector q (n,) -> Pinocchio's configuration (continuous joints as
    cos, sin; mimic joints left to Pinocchio, which computes them from their masters)."""
    out = np.zeros(model.nq)
    mimic = getattr(model, "mimic_from_xml", {})
    for jid in range(1, model.njoints):
        name = model.names[jid]
        if model.joints[jid].shortname() == "JointModelMimic":
            continue
        k = mech.joint_index(name)
        if name in mimic:
            master, mult, off = mimic[name]
            out[model.joints[jid].idx_q] = mult * q[mech.joint_index(master)] + off
            continue
        iq, nq = model.joints[jid].idx_q, model.joints[jid].nq
        if nq == 1:
            out[iq] = q[k]
        else:  # continuous (unbounded revolute)
            out[iq], out[iq + 1] = np.cos(q[k]), np.sin(q[k])
    return out


def pin_frames(pin, model, data, qpin: np.ndarray, names: list[str]) -> np.ndarray:
    """Poses (k, 4, 4) of Pinocchio's frames ``names`` (links, fixed-joint children)."""
    pin.framesForwardKinematics(model, data, qpin)
    return np.stack([data.oMf[model.getFrameId(n)].homogeneous for n in names])


def random_q_v(mech, rng, m: int) -> np.ndarray:
    """m random independent-joint vectors inside the limits (+-pi where unlimited)."""
    lo = np.where(np.isfinite(mech.lower), mech.lower, -np.pi)[mech.independent]
    hi = np.where(np.isfinite(mech.upper), mech.upper, np.pi)[mech.independent]
    return rng.uniform(lo, hi, size=(m, len(mech.independent)))
