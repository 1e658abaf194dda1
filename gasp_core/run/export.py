"""``gasp export RUN --format glb|usd|... -o OUT``: an existing run's frames in another format of the registry
(:mod:`gasp_core.gs.registry`).

* a per-frame format (``glb``, ``ply``, ``spz``, ...): ``OUT`` is a folder, ``OUT/<object>/frame_NNNN<suffix>``,
  every frame whole (the ``frames`` layout), written into a partial folder and moved into place at the end
  (:func:`gasp_core.fsutil.output_folder`; an existing ``OUT`` is refused unless ``overwrite``, and then only
  one written by gasp is replaced);
* a whole-run format: ``OUT`` is one file, written beside itself and renamed: ``usd`` a ``.usdc``, ``.usd`` or
  ``.usda`` (:mod:`gasp_core.run.usd_export`), ``glb_sequence`` a ``.glb`` that plays the run
  (:mod:`gasp_core.run.glb_sequence`).

The up axis of each object's file frame comes from the run's ``run.json`` (``objects[k].up_axis``), the frame
rate from its ``frame_dt``.

**Crack faces.** An object of the ``brittle`` material has crack-face Gaussians beside each frame
(``<object>/crack_faces_NNNN.ply``, :mod:`gasp_core.run.crack_output`); the export carries them (unless
``crack_faces=False``, ``--no-crack-faces``):

* per-frame formats: the faces *shown* at that frame, hidden ones left out (each frame's file stands alone, and a
  hidden face would cost a viewer its sort and memory for nothing: 9 844 on the README donut beside its 45 624):
  ``glb`` a second node ``<object>_crack_faces`` in the frame's file (after the object's, named as without
  faces); the single-cloud formats (``ply``, ``spz``, ...) after the object's rows, which stay first and
  unchanged (:func:`gasp_core.run.crack_output.with_crack_faces`); ``export.json`` records each object's shown
  count per frame (``crack_faces``). A frame with none shown (frame 0) is written as without faces.
* ``usd``: one more prim ``/Run/<object>_crack_faces`` holding every face, time-sampled with its opacity (0 while
  hidden): a time-sampled particle field keeps one count over the run, so its samples interpolate
  (:func:`gasp_core.run.usd_export.write_usd`); with ``--split-pieces`` each piece's prim has its own (as before).
* ``glb_sequence``: each frame's node holds that frame's shown faces after its rows.
"""
from __future__ import annotations

from pathlib import Path

from gasp_core.errors import GaspError, SceneError
from gasp_core.fsutil import atomic_json, output_folder
from gasp_core.gs import registry
from gasp_core.gs.gltf import write_glb_nodes
from gasp_core.run import split_pieces as split
from gasp_core.run.crack_output import shown_crack_faces, with_crack_faces
from gasp_core.run.layout import open_frames
from gasp_core.run.run_json import check_run_json
from gasp_core.run.usd_export import write_usd

#: What :func:`export_run` writes beside the frames of a per-frame export.
EXPORT_RECORD = "export.json"


def run_facts(folder: Path) -> tuple[float, dict[str, str], set[str]]:
    """``frame_dt`` (s), each object's up axis (name -> ``+z`` ...) and the names of static objects, from the
    run's ``run.json``.

    Raises
    ------
    SceneError
        No readable ``run.json``, or a field of it that is not what gasp simulate writes
        (:func:`gasp_core.run.run_json.check_run_json`; one line naming it).
    """
    run = check_run_json(folder)   # frame_dt > 0, object names one path component, up axes known
    up = {o["name"]: o.get("up_axis", "+z") for o in run["objects"]}
    static = {o["name"] for o in run["objects"] if o.get("static")}
    return float(run["frame_dt"]), up, static


def check_sidecars(run, n_frames: int, names: list[str], split_pieces: bool, crack_faces: bool,
                   allow_missing: bool) -> None:
    """Refuse (or, ``allow_missing``, warn once about) the pieces and crack-face files a damaged run lacks
    (:func:`gasp_core.run.split_pieces.missing_sidecars`), naming every one (the first 8 and how many in all).

    Raises
    ------
    SceneError
        Some are missing and ``allow_missing`` is false.
    """
    import warnings
    missing = split.missing_sidecars(run, n_frames, names, pieces=split_pieces, faces=crack_faces)
    if not missing:
        return
    listed = ", ".join(missing[:8]) + (f" and {len(missing) - 8} more" if len(missing) > 8 else "")
    said = f"{run}: {len(missing)} sidecar file(s) of a brittle object missing (a damaged run): {listed}"
    if not allow_missing:
        raise SceneError(f"{said}; restore them, or pass --allow-missing to export those frames without them "
                         "(unsplit, without crack faces)")
    warnings.warn(f"{said}: those frames exported without them (--allow-missing)", stacklevel=2)


def export_run(run, fmt: str, out, *, overwrite: bool = False, into_run: bool = False,
               split_pieces: bool = False, crack_faces: bool = True, allow_missing: bool = False) -> dict:
    """Write the frames of the run folder ``run`` in format ``fmt`` to ``out`` (module notes). ``into_run``: the
    run's own partial folder takes a whole-run file (``gasp simulate --format usd``); otherwise ``out`` must lie
    outside the run folder. ``split_pieces``: each piece of a broken body its own node or prim
    (:mod:`gasp_core.run.split_pieces`; ``glb`` and ``usd`` only). ``crack_faces``: a brittle object's crack faces
    in the export (module notes); false leaves them out. ``allow_missing``: a damaged run's missing pieces and
    crack-face files (:func:`check_sidecars`) are warned about, not refused.

    Returns
    -------
    dict
        ``format``, ``output``, ``n_frames``, ``objects`` (names) and ``files`` (count written).

    Raises
    ------
    GaspError
        ``fmt`` not an output format, or its library missing (the install line); ``out`` inside the run folder;
        ``split_pieces`` with another format or a run without pieces.
    FileExistsError, OutputConflict
        ``out`` exists and ``overwrite`` is false (or it is not gasp's to replace).
    SceneError
        Not a run folder (no ``frames.json`` or ``run.json``), or a frame that cannot be read.
    """
    run, out = Path(run), Path(out)
    spec = registry.check_writer(fmt)
    if not into_run and (out.resolve() == run.resolve() or run.resolve() in out.resolve().parents):
        raise GaspError(f"-o {out}: inside the run folder {run}; write the export somewhere else")
    frame_dt, up, static = run_facts(run)   # run.json checked before any frame is read
    frames = open_frames(run)
    names = [o["name"] for o in frames.manifest["objects"]]
    ups = [up.get(n, "+z") for n in names]
    check_sidecars(run, frames.n_frames, names, split_pieces, crack_faces, allow_missing or into_run)
    last = split.check_split(run, fmt, frames, names) if split_pieces else None
    if spec.sequence:
        suffixes = (".usda",) + spec.suffixes if fmt == "usd" else spec.suffixes
        if out.suffix.lower() not in suffixes:
            raise GaspError(f"-o {out}: --format {fmt} writes one file; expected a name ending in "
                            f"{' or '.join(suffixes)}")
        if out.exists() and not overwrite:   # said in the command's words, before any frame is read
            raise FileExistsError(f"-o {out}: the file exists; pass --overwrite to replace it")
        moving = [not bool(frames.manifest["objects"][k].get("static")) and n not in static
                  for k, n in enumerate(names)]
        faces = split.usd_faces(run, names) if crack_faces else None
        if last is not None:
            write_usd(out, frames, names, ups, frame_dt, moving, overwrite=overwrite,
                      pieces=[None if a is None else split.parts_of(a, "") for a in last], crack_faces=faces)
        else:
            registry.load(spec.sequence)(out, frames, names, ups, frame_dt, moving, overwrite=overwrite,
                                         crack_faces=faces)
        return {"format": fmt, "output": str(out), "n_frames": frames.n_frames, "objects": names, "files": 1}
    count, shown = 0, {}
    with output_folder(out, overwrite=overwrite, protected=[run]) as tmp:
        for k, name in enumerate(names):
            (tmp / name).mkdir()
            for f in range(frames.n_frames):
                path, g = tmp / name / f"frame_{f:04d}{spec.suffix}", frames.gaussians(f, k)
                labels = None if last is None else split.frame_labels(run, name, f, g.n)
                faces = shown_crack_faces(run, name, f) if crack_faces and labels is None else None
                if faces is not None:
                    shown.setdefault(name, []).append(faces.n)
                if labels is not None:
                    write_glb_nodes(path, split.glb_parts(run, name, f, g, labels, with_faces=crack_faces),
                                    up_axis=ups[k])
                elif faces is not None and faces.n and fmt == "glb":
                    # the object's node named as write_glb names a frame's (its file's stem), then the faces'
                    write_glb_nodes(path, [(Path(g.source or "splats").stem, g), (f"{name}_crack_faces", faces)],
                                    up_axis=ups[k])
                elif faces is not None and faces.n:
                    registry.write(path, with_crack_faces(g, faces), fmt, up_axis=ups[k])
                else:
                    registry.write(path, g, fmt, up_axis=ups[k])
                count += 1
        atomic_json(tmp / EXPORT_RECORD, {"format": fmt, "from_run": str(run.resolve()), "n_frames": frames.n_frames,
                                          "frame_dt": frame_dt, "objects": names, "up_axes": ups,
                                          **({"split_pieces": True} if split_pieces else {}),
                                          **({"crack_faces": shown} if shown else {})})
    return {"format": fmt, "output": str(out), "n_frames": frames.n_frames, "objects": names, "files": count}
