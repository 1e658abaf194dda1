"""The studio page's panels (viser GUI): messages, selection, material, scene, run, keep.

The form only gathers values; :meth:`Form.apply` writes them into the studio's scene document and the scene
checker (:func:`gasp_core.scene.spec.parse_scene`) judges them, so a bad value is refused in the page with the
same line ``gasp simulate`` prints. Inputs carry no ranges of their own for that reason.
"""
from __future__ import annotations

import copy
from pathlib import Path

from gasp_core.errors import GaspError, SceneError
from gasp_core.studio.guard import inside
from gasp_core.scene.values import UP_AXES
from gasp_core.scene.quality import QUALITY_LEVELS, STUDIO_LEVEL, studio_engine_rank
from gasp_core.seam.schema import DEFAULT_MATERIAL, MATERIAL_KINDS, MATERIAL_PARAMS

#: Typical values a material starts with, and where they come from (the rest: the schema's defaults).
TYPICAL = {
    "jelly": ({"E": 2.0e4, "nu": 0.3, "rho": 300.0, "viscosity": 4.0},
              "the README donut (examples/donut_jelly.toml; viscosity: docs/dissipation.md, 'Typical values')"),
    "neo_hookean": ({"E": 2.0e4, "nu": 0.3, "rho": 300.0, "viscosity": 4.0}, "as jelly"),
    "sand": ({"E": 3.0e5, "nu": 0.3, "rho": 1600.0, "friction_angle": 35.0}, "examples/guitar_sand.toml"),
    "brittle": ({"E": 2.0e5, "nu": 0.25, "rho": 300.0, "tensile_strength": 1.0e4, "fracture_energy": 10.0},
                "a ball of it breaks into pieces landing from 1 m (tests/test_brittle.py, docs/fracture.md)"),
}


#: The material menu's first entry while none is chosen (a file opened alone): nothing is preselected, so the
#: user's pick is what runs, and Run asks for one.
CHOOSE = "(choose a material)"

#: What the quality menu says of the studio's level (measured: docs/studio.md, "Time to the first frame").
STUDIO_HINT = (f"{STUDIO_LEVEL}: the studio's level, the cheapest; the donut's first frame about 15-20 s after Run "
               "on 2 CPU cores from a cold kernel cache, 5 s warm (docs/studio.md)")


def typical(material: str) -> dict:
    """Starting values of ``material``'s keys: :data:`TYPICAL`, else each key's schema default (none for
    :data:`CHOOSE`)."""
    if material not in MATERIAL_KINDS:
        return {}
    given = TYPICAL.get(material, ({}, ""))[0]
    return {k: given.get(k, MATERIAL_PARAMS[k].default) for k in MATERIAL_KINDS[material].keys}


def installed_engines(material: str | None = None) -> list[str]:
    """Engines installed and able to run here (and, given ``material``, offering it), best first
    (:func:`gasp_core.scene.quality.studio_engine_rank`)."""
    from gasp_core.seam.plugins import engines
    material = None if material == CHOOSE else material
    ok = [info for info in engines().values() if info.unavailable_reason() is None and
          (material is None or material in info.capabilities.materials)]
    return [info.name for info in sorted(ok, key=studio_engine_rank)]


class Form:
    """The page's controls for one :class:`gasp_core.studio.app.Studio`, top to bottom in the order of the work
    (the newest message, select, material, run, then the scene's placement, keep and the earlier messages), so
    that Run sits within the first 800 px of a 1280 x 800 window (tests/test_studio_browser.py)."""

    def __init__(self, studio):
        self.studio = studio
        gui = studio.server.gui
        sc = studio.scene
        self.messages = gui.add_markdown("**GASP studio**: click an object to select it")
        with gui.add_folder("Select"):
            self.selection = gui.add_markdown("nothing selected")
            gui.add_markdown("click: select a piece · shift-click: add · click a selected piece: remove · "
                             "ctrl-drag: box (ctrl-shift: add)")
            self.clear = gui.add_button("Clear selection")
        obj = self._target_object()
        mat = dict(obj.get("material", {}))
        name = mat.get("name", DEFAULT_MATERIAL)
        offered = sorted({m for e in installed_engines() for m in self._materials_of(e)}) or list(MATERIAL_KINDS)
        chosen = "name" in mat and name in offered           # a scene that names its material; a file: none
        with gui.add_folder("Material") as self.material_folder:
            self.material = gui.add_dropdown("Material", offered if chosen else [CHOOSE, *offered],
                                             initial_value=name if chosen else CHOOSE)
            self.typical_button = gui.add_button("Typical values")
        self.values: dict = {}
        self._value_inputs(mat if name == self.material.value else {})
        with gui.add_folder("Run"):
            engines_now = installed_engines(self.material.value) or ["(none installed)"]
            want = sc.doc.get("engine", {}).get("name")
            self.engine = gui.add_dropdown("Engine", engines_now,
                                           initial_value=want if want in engines_now else engines_now[0])
            self.quality = gui.add_dropdown("Quality", list(QUALITY_LEVELS), hint=STUDIO_HINT,
                                            initial_value=sc.doc.get("quality", STUDIO_LEVEL) if not sc.is_file
                                            else STUDIO_LEVEL)
            self.frames = gui.add_number("Frames", int(sc.doc.get("n_frames", 30)), step=1)
            self.run_button = gui.add_button("Run")
            self.stop_button = gui.add_button("Stop")
            self.resume_button = gui.add_button("Resume")
            self.run_status = gui.add_markdown("no run yet")
            self.timeline = gui.add_slider("Frame", min=0, max=1, step=1, initial_value=0, disabled=True)
            self._n_ready = 0
        with gui.add_folder("Scene"):
            guess = sc.up_guess
            label = "Up axis" + ("" if guess is None else f" (guessed {guess.up}, {guess.confidence:.2f})"
                                 if guess.up != "unknown" else f" (unknown{', leans ' + guess.lean if guess.lean else ''}: "
                                                               "check it)")
            self.up = gui.add_dropdown(label, list(UP_AXES), initial_value=obj.get("up_axis", "+z"),
                                       disabled=not sc.is_file)
            self.scale = gui.add_number("Scale (m per file unit)", float(obj.get("scale", 1.0)), disabled=not sc.is_file)
            self.drop = gui.add_number("Drop height (m)", float(obj.get("position", [0, 0, 0.05])[2]),
                                       disabled=not sc.is_file)
            self.ground = gui.add_checkbox("Ground", initial_value=any(b.get("kind") == "ground" for b in
                                                                        sc.doc.get("boundary", [])),
                                           disabled=not sc.is_file)
        with gui.add_folder("Keep", expand_by_default=False):
            gui.add_markdown(f"files are written in {studio.save_dir} (--save-dir)")
            self.save_path = gui.add_text("Scene file", f"{sc.path.stem}_studio.toml")
            self.overwrite = gui.add_checkbox("Overwrite", initial_value=False,
                                              hint="replace a file this studio wrote earlier in this session")
            self.save_button = gui.add_button("Save scene")
            self.export_path = gui.add_text("Page", "", hint="default: the run's name, .html")
            self.export_button = gui.add_button("Export page")
        with gui.add_folder("Earlier messages", expand_by_default=False):
            self.history = gui.add_markdown("-")
        self._wire()

    # -- building ---------------------------------------------------------------------------------------
    @staticmethod
    def _materials_of(engine: str) -> list[str]:
        from gasp_core.seam.plugins import engines
        return [m for m in engines()[engine].capabilities.materials if m in MATERIAL_KINDS]

    def _target_object(self) -> dict:
        """The object the material applies to: the first with a selection, else the first that is not static."""
        objs = self.studio.scene.doc["object"]
        for p in self.studio.scene.pieces:
            if p.selected.any():
                return objs[p.index]
        return next((o for o in objs if not o.get("static", False)), objs[0])

    def _value_inputs(self, given: dict) -> None:
        """One number input per key of the chosen material (given values, else :func:`typical`)."""
        for h in self.values.values():
            h.remove()
        start = {**typical(self.material.value), **{k: v for k, v in given.items() if k != "name"}}
        with self.material_folder:
            self.values = {k: self.studio.server.gui.add_number(
                f"{k} ({MATERIAL_PARAMS[k].unit})" if MATERIAL_PARAMS[k].unit else k, float(v),
                hint=MATERIAL_PARAMS[k].doc) for k, v in start.items()}

    def _wire(self) -> None:
        """Each control's callback, behind :meth:`Studio.guarded` (anything it raises: one line in the page)."""
        st = self.studio
        g = st.guarded
        self.clear.on_click(g("Clear selection", lambda _: self._clear()))
        self.material.on_update(g("Material", lambda _: self._material_changed()))
        self.typical_button.on_click(g("Typical values", lambda _: self._value_inputs({})))
        self.run_button.on_click(g("Run", lambda _: st.run()))
        self.stop_button.on_click(g("Stop", lambda _: st.stop_run()))
        self.resume_button.on_click(g("Resume", lambda _: st.run(resume=True)))
        self.timeline.on_update(g("Frame", lambda _: st.show_frame(int(self.timeline.value))))
        self.save_button.on_click(g("Save scene", lambda _: self.save()))
        self.export_button.on_click(g("Export page", lambda _: self.export()))
        for h in (self.up, self.scale, self.drop, self.ground):
            h.on_update(g(h.label, lambda _: self._placement_changed()))
        for h in (self.material, self.engine, self.quality, self.ground, self.frames):   # the run to hold (studio.warm)
            h.on_update(lambda _: setattr(st, "warm_wanted", st.warmer is not None))

    def _clear(self) -> None:
        for p in self.studio.scene.pieces:
            p.selected[:] = False
        self.studio._retint()
        self.studio._said("selection cleared")

    def _material_changed(self) -> None:
        self._value_inputs({})
        engines_now = installed_engines(self.material.value) or ["(none installed)"]
        keep = self.engine.value
        self.engine.options = engines_now
        self.engine.value = keep if keep in engines_now else engines_now[0]

    def _placement_changed(self) -> None:
        try:
            self.studio.scene.replace(self.document())
        except GaspError as e:
            self.studio.say(str(e))
            return
        self.studio._draw()

    # -- reading ----------------------------------------------------------------------------------------
    def document(self, warm: bool = False) -> dict:
        """The studio's document with the form's values written in (not checked); no material chosen yet: the
        document's own, or with ``warm`` the default model's typical values (what a warm-up builds)."""
        sc = self.studio.scene
        doc = copy.deepcopy(sc.doc)
        target = self._target_object()
        k = sc.doc["object"].index(target)
        if self.material.value != CHOOSE:
            doc["object"][k]["material"] = {"name": self.material.value,
                                            **{key: float(h.value) for key, h in self.values.items()}}
        elif warm:
            # as the number inputs give them once the material is picked: the same run (gasp_core.studio.warm)
            doc["object"][k]["material"] = {"name": DEFAULT_MATERIAL,
                                            **{key: float(v) for key, v in typical(DEFAULT_MATERIAL).items()}}
        if sc.is_file:
            o = doc["object"][k]
            o["up_axis"], o["scale"] = self.up.value, float(self.scale.value)
            o["position"] = [0.0, 0.0, float(self.drop.value)]
            doc["boundary"] = [{"kind": "ground", "height": 0.0, "friction": 0.5}] if self.ground.value else []
        doc.setdefault("engine", {})["name"] = self.engine.value
        doc["quality"] = self.quality.value
        frames = self.frames.value
        doc["n_frames"] = int(frames) if float(frames).is_integer() else frames
        return doc

    def apply(self) -> None:
        """The form's values into the studio's document (the scene checker judges them first).

        Raises
        ------
        SceneError
            The checker's one line, or no material chosen; the document is left as it was.
        """
        if self.material.value == CHOOSE:
            raise SceneError("choose a material first (the Material menu): nothing is preselected")
        self.studio.scene.replace(self.document())

    def may_replace(self, files: list[Path]) -> bool:
        """Whether writing ``files`` may replace those that exist: none exists, or **Overwrite** is ticked and
        each existing one is a file the studio wrote this session (:attr:`Studio.written`).

        Raises
        ------
        SceneError
            An existing file the studio did not write, or Overwrite not ticked (one line; nothing written).
        """
        existing = [f for f in files if f.exists() or f.is_symlink()]
        if not existing:
            return False
        if not self.overwrite.value:
            raise SceneError(f"{existing[0]} exists; choose another name (or tick Overwrite)")
        foreign = [f for f in existing if f.resolve() not in self.studio.written or f.is_symlink()]
        if foreign:
            raise SceneError(f"{foreign[0]} exists and was not written by this studio session; Overwrite replaces "
                             "only the studio's own files: choose another name")
        return True

    def save(self) -> str:
        """Save the scene as the file the page names inside the studio's folder (with its masks beside it)."""
        st = self.studio
        try:
            path = inside(st.save_dir, self.save_path.value, "Scene file", ".toml")
            self.apply()
            sc = st.scene
            masks = [sc.mask_path(p.index, path.parent, path.stem) for p in sc.pieces if p.selected.any()]
            out = sc.write(path, overwrite=self.may_replace([path, *masks]))
        except (GaspError, OSError) as e:
            return st._said(str(e))
        st.written.update(f.resolve() for f in [out, *masks])
        return st._said(f"saved {out}: 'gasp simulate {out} -o OUT' reproduces the studio's run")

    def export(self) -> str:
        """Export the finished run as one page, the file the page names inside the studio's folder."""
        from gasp_core.render.export import export_page
        st = self.studio
        if st.stream is None or st.stream.job.outcome() != "finished":
            return st._said("export needs a finished run: run the scene to its end first")
        try:
            page = inside(st.save_dir, self.export_path.value or st.stream.outdir.name + ".html", "Page", ".html")
            out = export_page(st.stream.outdir, page, overwrite=self.may_replace([page]))
        except (GaspError, OSError) as e:
            return st._said(str(e))
        st.written.add(Path(out).resolve())
        return st._said(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB; opens from disk in a browser)")

    # -- showing ----------------------------------------------------------------------------------------
    def set_messages(self, lines: list[str]) -> None:
        """The newest line at the top of the page, the ones before it in "Earlier messages" (folded)."""
        self.messages.content = f"**{lines[0]}**" if lines else ""
        self.history.content = "\n\n".join(lines[1:]) or "-"

    def set_selection(self, text: str) -> None:
        self.selection.content = text

    def set_run_status(self, text: str) -> None:
        if self.run_status.content != text:
            self.run_status.content = text

    def reset_timeline(self) -> None:
        """A new run (or a resumed one, whose kept frames are read again): the slider starts empty."""
        self._n_ready = 0
        self.timeline.value = 0
        self.timeline.max = 1
        self.timeline.disabled = True

    def timeline_grew(self, n_ready: int) -> None:
        """New frames: the slider reaches them, and follows the newest while it sat on the newest before."""
        at_end = self.studio._frame_shown < 0 or int(self.timeline.value) >= self._n_ready - 1
        self._n_ready = n_ready
        self.timeline.disabled = False
        self.timeline.max = max(n_ready - 1, 1)
        if at_end:
            self.timeline.value = n_ready - 1
            self.studio.show_frame(n_ready - 1)
