"""Run a scene (or its experiment) and publish the run folder (used by `whisker sim`)."""

from __future__ import annotations

import time
from pathlib import Path

from whisker.sim.experiments import repeat as ex
from whisker.sim.run import finite_summary, plot_angles, png_bytes, tracks_csv, write_run
from whisker.sim.simulate import simulate


def run_scene(scene, design, plan, out: Path, progress=None, jobs: int = 1) -> dict:
    """Simulate `scene` (its experiment if it has one); write the run folder; return the summary."""
    t0 = time.perf_counter()
    kind = scene.experiment.kind
    files: dict[str, bytes | str] = {"plan.json": _json(plan.to_dict())}
    summary: dict = {"scene": scene.scene.name, "experiment": kind, "design_digest": design.digest(),
                     "effects": plan.names, "solver": plan.solver}
    if kind == "none":
        cam_on = plan.built("camera")
        res = simulate(scene, design, plan, progress=(lambda f: progress(0.5 * f)) if progress and cam_on else progress)
        if cam_on:
            from whisker.sim.camera import camera_run, png_frame, video_bytes
            keep = scene.outputs.frames or scene.outputs.video
            cr = camera_run(scene, design, res, keep_frames=keep, track=plan.built("tracking"),
                            progress=(lambda f: progress(0.5 + 0.5 * f)) if progress else None)
            if scene.outputs.frames:
                for k, img in enumerate(cr.frames):
                    files[f"frames/frame_{k:05d}.png"] = png_frame(img)
            if scene.outputs.video:
                files["video.mp4"] = video_bytes(cr.frames, scene.camera.fps)
            if cr.est_tip_mm is not None:
                rows = ["t_s,whisker,true_tip_dx_mm,true_tip_dy_mm,est_tip_dx_mm,est_tip_dy_mm,valid"]
                for k, t in enumerate(cr.t_s):
                    for i in range(cr.true_tip_mm.shape[1]):
                        tx, ty = cr.true_tip_mm[k, i]
                        ex_, ey = cr.est_tip_mm[k, i]
                        rows.append(f"{t:.6g},{i},{tx:.6g},{ty:.6g},{ex_:.6g},{ey:.6g},{int(cr.valid[k, i])}")
                files["camera_tracks.csv"] = "\n".join(rows) + "\n"
            summary["camera"] = cr.summary()
        if scene.outputs.tracks:
            files["tracks.csv"] = tracks_csv(res)
        if scene.outputs.plots and len(res.t_s) > 1:
            files["angles.png"] = png_bytes(lambda p: plot_angles(res, p, scene.scene.name))
        th = res.theta_deg[-1, :, 0]
        summary.update(final_tilt_deg=th.tolist(), steps=res.steps, sim_time_s=float(res.t_s[-1]),
                       max_energy_J=float(res.energy_J.max()))
        if res.objects_mm is not None:
            summary["objects_final_mm"] = {n: res.objects_mm[-1, i].tolist() for i, n in enumerate(res.object_names)}
        if res.info:
            summary.update(res.info)
        from whisker.sim.validate import run_flags

        summary["flags"] = run_flags(scene, res)
        summary["headline"] = f"final tilt (deg): {', '.join(f'{x:+.2f}' for x in th)}"
        if "camera" in summary and "tip_rms_mm" in summary["camera"]:
            c = summary["camera"]
            summary["headline"] += (f"\ncamera -> tracker -> geometry: tip RMS error {c['tip_rms_mm']:.4f} mm "
                                    f"(max {c['tip_max_mm']:.4f} mm) over {c['frames']} frames")
    elif kind == "angle_vs_voltage":
        r = ex.angle_vs_voltage(scene, design)
        files["angle_vs_voltage.md"] = ex.angle_table(r)
        files["angle_vs_voltage.csv"] = "volts,current_A,theta_deg,at_stop\n" + "".join(
            f"{v:.6g},{i:.6g},{t:.6g},{int(s)}\n" for v, i, t, s in zip(r["volts"], r["current_A"], r["theta_deg"], r["at_stop"]))
        if scene.outputs.plots:
            files["angle_vs_voltage.png"] = png_bytes(lambda p: ex.plot_angle_vs_voltage(r, p))
        summary.update(volts=r["volts"], theta_deg=r["theta_deg"], at_stop=r["at_stop"])
        summary["headline"] = "angle vs voltage:\n" + ex.angle_table(r)
    else:
        from whisker.sim.experiments import paper
        summary.update(paper.run(kind, scene, design, files, progress=progress, jobs=jobs))
    summary["wall_time_s"] = time.perf_counter() - t0
    if progress:
        progress(1.0)
    write_run(out, files, finite_summary(summary))
    return summary


def _json(d) -> str:
    import json
    return json.dumps(d, indent=2) + "\n"
