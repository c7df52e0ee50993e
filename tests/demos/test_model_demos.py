"""The demos of several bodies and of axisymmetry (issue 21 item 5), in-process on the suite's
ranks, checked against closed forms and statics.

* ``shrink_fit`` (axisymmetric, P2): the fit's contact pressure against Lamé (plane strain, the
  penalty's compliance in series) within 0.5 % at every interface point; pushed off, Coulomb's
  fit slides at ``2 pi b L mu p`` (within 0.5 %); the subloading law's force rises smoothly (a
  concave curve from the first increment, every point plastic) below its saturation bound
  ``2 pi b L g(p) mu_s``.
* ``bolt_clamped_joint`` (3-D, four bodies, three interfaces): at every step the bolt's axial
  force (from the shank's stress) equals the normal resultants of the head face, the joint (the
  clamping force) and the nut face, to Newton's tolerance; cyclic shear draws a loop that
  dissipates energy.
"""

import numpy as np

from demos import bolt_clamped_joint, shrink_fit
from tests.helpers import everywhere


def test_shrink_fit_against_lame_and_the_coulomb_push_off_force(comm, shared_tmp):
    res = shrink_fit.main(["--h", "2.5", "--steps", "8", "--out", str(shared_tmp)], comm)
    r = res["report"]
    sub = np.array([h["force"] for h in res["results"]["subloading"]["history"]])
    sub = sub[1:]  # after the fit
    peak = int(np.argmax(sub))
    rise = np.diff(np.concatenate([[0.0], sub[: peak + 1]]))
    plastic = [h["plastic"] for h in res["results"]["subloading"]["history"][1:]]
    checks = {
        "Lame, mean": abs(r["p_mean_error"]) < 5e-3,
        "Lame, every point": r["p_max_error"] < 5e-3,
        "Coulomb push-off": abs(r["coulomb_onset_error"]) < 5e-3,
        "subloading concave": bool(np.all(np.diff(rise) <= 1e-9 * sub.max())),
        "subloading plastic from the start": min(plastic) == 1.0,
        "subloading below saturation": r["subloading_peak"] < r["subloading_bound"],
    }
    assert everywhere(comm, all(checks.values())), (checks, r)


def test_bolted_joint_force_balance_at_every_step(comm, shared_tmp):
    res = bolt_clamped_joint.main(
        ["--h", "4", "--cycles", "1", "--dt", "0.5", "--out", str(shared_tmp)], comm
    )
    rows, r = res["history"], res["report"]
    u = np.array([h["shear"] for h in rows])
    f = np.array([h["force"] for h in rows])
    work = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(u)))  # around the closed cycle
    checks = {
        # 1e-8, or what Newton's stop allows if a step ended above that (round-off differences
        # of a parallel LU can change a step's last iterate: it is then at rtol |F_0|)
        "balance": r["balance"] < max(1e-8, r["balance_newton"]),
        "pretension": r["pretension"] > 1e3,
        "both directions": r["shear_max"] > 0 > r["shear_min"],
        "a loop that dissipates": abs(work) > 1e-3 * r["shear_max"] * bolt_clamped_joint.SHEAR,
    }
    assert everywhere(comm, all(checks.values())), (checks, r, work)
