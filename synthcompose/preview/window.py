"""``synthcompose preview``: a window for debugging placement (GLFW; ``pip install 'synthcompose[preview]'``).

The window's OpenGL context is the only one: it is wrapped in a :class:`~synthcompose.render.gl.GLContext`
and the batch's own Pipeline, Renderer and Composer render into it (:mod:`.session` does the work,
:mod:`.overlay` the text; this module only shows it and maps keys and the mouse; it imports GLFW lazily).

The keys are :data:`KEYS`. Every shown pose is checked against the batch's placement rules; the
verdict (OK, or the object, the rule it breaks and why) is on the overlay drawn over the view
(pass, image set, placement, verdict, last message; in the 3D view the legend of colours), and
S refuses to save a pose that fails (Shift+S saves it anyway). 3D view: left drag orbits, right
(or middle) drag pans, the wheel zooms.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthcompose.errors import SynthComposeError
from synthcompose.manifest import Manifest
from synthcompose.render.gl import GLContext
from synthcompose.render.transforms import gl_mat4

from . import overlay as ov
from .export import BOX_EDGES, box_mesh, plane_quad
from .orbit import Orbit
from .overlay import Overlay, view_legend
from .session import PASS_TITLES, PASSES, STEP_M, STEP_YAW_DEG, PlacementRefused, PreviewSession

#: (key, what it does): the console and on-screen help
KEYS = (
    ("1-9", "pass: composed, Irpv, Ir, alpha, object ID, object depth, scene depth, occlusion mask, semantic"),
    ("N / P", "next / previous image set"),
    ("R", "re-roll: a new random placement"),
    ("arrows", f"move the selected object {STEP_M * 100:.0f} cm on the ground (Shift: x4)"),
    ("Q / E", f"turn it {STEP_YAW_DEG:.0f} deg (Shift: x4)"),
    ("Tab", "select the next object"),
    ("S", "save the placement (refused while a placement rule fails)"),
    ("Shift+S", "save anyway, rules or not"),
    ("V", "3D view: left drag orbits, right drag pans, wheel zooms"),
    ("C", "colour the cloud by photo / label"),
    ("X", "export PLY"),
    ("O", "overlay on / off"),
    ("H", "this help on / off"),
    ("Esc", "quit"),
)
HELP = "\n".join(f"{k:<8} {what}" for k, what in KEYS)
MAX_WINDOW = (1600, 900)


def _import_glfw():
    try:
        import glfw
    except ImportError:
        raise SynthComposeError("the preview window needs GLFW: pip install 'synthcompose[preview]'") from None
    return glfw


class PreviewWindow:
    """The window: shows a :class:`PreviewSession` and maps keys and the mouse to it."""

    def __init__(self, manifest: Manifest, frame: str | None = None, visible: bool = True,
                 size: tuple[int, int] | None = None, quiet: bool = False) -> None:
        import moderngl

        glfw = self.glfw = _import_glfw()
        if not glfw.init():
            raise SynthComposeError("cannot open a window: GLFW found no display (is DISPLAY set?)")
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.VISIBLE, visible)
        glfw.window_hint(glfw.RESIZABLE, True)
        self.window = glfw.create_window(640, 480, "synthcompose preview", None, None)
        if not self.window:
            glfw.terminate()
            raise SynthComposeError("cannot open a window with an OpenGL 3.3 core context")
        glfw.make_context_current(self.window)
        glfw.swap_interval(1)
        self.ctx = moderngl.create_context(require=330)
        self.gl = GLContext.wrap(self.ctx)
        self.quiet = quiet
        self.session = PreviewSession(manifest, frame, gl=self.gl)
        self.blit = self.gl.program("preview_blit")
        self.blit_vao = self.gl.own(self.ctx.vertex_array(self.blit, []))
        self.overlay_blit = self.gl.program("preview_blit", OVERLAY=1)
        self.overlay_vao = self.gl.own(self.ctx.vertex_array(self.overlay_blit, []))
        self.overlay_tex = None
        self.overlay_pixels: np.ndarray | None = None  # (H, W, 4) RGBA last drawn over the view
        self._overlay_key = None
        self.show_overlay, self.show_help = True, False
        self.message = ""  # the last action's result (saved, refused...), on the overlay
        self.points = self.gl.program("preview_points")
        self.image_tex = None
        self.pass_index = 0
        self.mode_3d = False
        self.colour_by = "rgb"
        self.orbit = Orbit()
        self._geometry: list = []  # (vao, mode, point size)
        self._drag: tuple[int, float, float] | None = None
        self.dirty = True
        self._fixed_size = size
        self._sized_for: tuple[int, int] | None = None
        glfw.set_key_callback(self.window, self.on_key)
        glfw.set_mouse_button_callback(self.window, self.on_mouse_button)
        glfw.set_cursor_pos_callback(self.window, self.on_cursor)
        glfw.set_scroll_callback(self.window, self.on_scroll)
        self.reload(self.session.load())

    # --------------------------------------------------------------------------- state
    @property
    def pass_name(self) -> str:
        return PASSES[self.pass_index]

    def _say(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    def _note(self, text: str) -> None:
        """Say ``text`` on the console and on the overlay."""
        self.message = text
        self._say(text)

    def reload(self, view=None) -> None:
        """After the session changed: new image, new 3D geometry, title, legend."""
        v = self.session.view
        self.message = ""
        H, W = v.rgb.shape[:2]
        if self._sized_for != (W, H):
            if self._fixed_size:
                w, h = self._fixed_size
            else:
                s = min(1.0, MAX_WINDOW[0] / W, MAX_WINDOW[1] / H)
                w, h = int(round(W * s)), int(round(H * s))
            self.glfw.set_window_size(self.window, w, h)
            self._sized_for = (W, H)
            o = v.objects[self.session.selected].placement.position if v.objects else np.array([15.0, 0, 0])
            self.orbit.target = np.array(o, float)
        self._upload_image()
        self._build_geometry()
        self._update_title()
        for line in self.session.legend():
            self._say(line)
        self.dirty = True

    def _refill(self, tex, size: tuple[int, int], components: int, pixels: np.ndarray):
        """``tex`` with ``pixels`` written into it, or a new texture where it is missing or of
        another size (the old one freed)."""
        if tex is not None and tex.size == size:
            tex.write(np.ascontiguousarray(pixels).tobytes())
            return tex
        if tex is not None:
            self.gl.free(tex)
        return self.gl.texture(size, components, pixels)

    def _upload_image(self) -> None:
        import moderngl

        img = np.ascontiguousarray(self.session.pass_image(self.pass_name))
        H, W = img.shape[:2]
        self.image_tex = self._refill(self.image_tex, (W, H), 3, img)
        fw, fh = self.glfw.get_framebuffer_size(self.window)
        f = moderngl.NEAREST if (fw, fh) == (W, H) else moderngl.LINEAR
        self.image_tex.filter = (f, f)
        self.dirty = True

    def _build_geometry(self) -> None:
        import moderngl

        for vao, _, _, buf in self._geometry:
            self.gl.free(vao)
            self.gl.free(buf)
        self._geometry = []
        v = self.session.view

        def add(pos, col, mode, size=1.0):
            if len(pos) == 0:
                return
            data = np.hstack([np.asarray(pos, np.float32), np.asarray(col, np.float32) / 255.0]).astype(np.float32)
            buf = self.gl.own(self.ctx.buffer(data.tobytes()))
            vao = self.gl.own(self.ctx.vertex_array(self.points, [(buf, "3f 3f", "in_position", "in_color")]))
            self._geometry.append((vao, mode, size, buf))

        add(v.frame.cloud.vehicle, self.session.cloud_colours(self.colour_by), moderngl.POINTS, 1.0)
        lines, lcol = [], []
        for i, o in enumerate(v.objects):
            m = o.placement.matrix
            corners, _ = box_mesh(m, o.extents)
            c = ov.SELECTED_BOX_COLOUR if i == self.session.selected else ov.BOX_COLOUR
            for a, b in BOX_EDGES:
                lines += [corners[a], corners[b]]
                lcol += [c, c]
            q = plane_quad(m, o.extents)
            for t in np.linspace(0.0, 1.0, 5):  # the fitted ground plane as a grid
                for a, b, cc, d in ((0, 1, 3, 2), (0, 3, 1, 2)):
                    lines += [q[a] + t * (q[cc] - q[a]), q[b] + t * (q[d] - q[b])]
                    lcol += [ov.PLANE_COLOUR] * 2
        add(np.array(lines).reshape(-1, 3), np.array(lcol).reshape(-1, 3), moderngl.LINES)
        colours = v.reason_colour()
        if v.trace:
            add(np.array([p for p, _ in v.trace]), np.array([colours[w] for _, w in v.trace]), moderngl.POINTS, 7.0)
        if v.objects:
            add(np.array([o.placement.position for o in v.objects]), np.array([ov.ACCEPTED_COLOUR] * len(v.objects)),
                moderngl.POINTS, 10.0)

    @property
    def what(self) -> str:
        """What is shown: the pass, or the 3D view."""
        return f"3D view ({self.colour_by})" if self.mode_3d else f"{self.pass_index + 1}: {PASS_TITLES[self.pass_name]}"

    def overlay(self) -> Overlay:
        """The text over the view: what is shown, the image set, the placement and its verdict,
        the last message; the 3D view's colours; the keys when help is on."""
        s, v = self.session, self.session.view
        verdict = v.verdict
        colour = ov.NOTE_COLOUR if not v.objects else ov.OK_COLOUR if verdict.ok else ov.FAIL_COLOUR
        lines = [(f"{self.what} | {v.ident.key} ({s.index + 1}/{len(s.ids)}) | H: help", ov.TEXT_COLOUR),
                 (s.objects_line(), ov.TEXT_COLOUR), (str(verdict), colour)]
        if self.message:
            lines.append((self.message, ov.NOTE_COLOUR))
        return Overlay(tuple(lines), view_legend(v) if self.mode_3d else (),
                       tuple(f"{k}\t{what}" for k, what in KEYS) if self.show_help else ())

    def _update_title(self) -> None:
        v = self.session.view
        what = self.what
        top = sorted(v.reasons.items(), key=lambda kv: -kv[1])[:3]
        rej = "; ".join(f"{w} x{n}" for w, n in top) or "none"
        self.title = f"synthcompose preview - {what} - {self.session.status_line()} - rejected: {rej}"
        self.glfw.set_window_title(self.window, self.title)

    # ---------------------------------------------------------------------------- input
    def on_key(self, window, key, scancode, action, mods) -> None:
        glfw = self.glfw
        if action not in (glfw.PRESS, glfw.REPEAT):
            return
        s = self.session
        fast = 4.0 if mods & glfw.MOD_SHIFT else 1.0
        if glfw.KEY_1 <= key <= glfw.KEY_9:
            self.pass_index = key - glfw.KEY_1
            self.mode_3d = False
            self._upload_image()
            self._update_title()
        elif key in (glfw.KEY_N, glfw.KEY_P):
            s.step_set(1 if key == glfw.KEY_N else -1)
            self._sized_for = None
            self.reload()
        elif key == glfw.KEY_R:
            s.reroll()
            self.reload()
        elif key in (glfw.KEY_UP, glfw.KEY_DOWN, glfw.KEY_LEFT, glfw.KEY_RIGHT):
            d = {glfw.KEY_UP: (1, 0), glfw.KEY_DOWN: (-1, 0), glfw.KEY_LEFT: (0, 1), glfw.KEY_RIGHT: (0, -1)}[key]
            s.move(dx=d[0] * STEP_M * fast, dy=d[1] * STEP_M * fast)
            self.reload()
        elif key in (glfw.KEY_Q, glfw.KEY_E):
            s.move(dyaw_deg=(STEP_YAW_DEG if key == glfw.KEY_Q else -STEP_YAW_DEG) * fast)
            self.reload()
        elif key == glfw.KEY_TAB:
            s.select_next()
            self._build_geometry()
            self._update_title()
        elif key == glfw.KEY_S:
            force = bool(mods & glfw.MOD_SHIFT)
            try:
                path = s.save(force=force)
            except PlacementRefused as exc:
                self._say(str(exc))  # the console gets the whole verdict, the overlay has it already
                self.message = exc.short
            else:
                anyway = " anyway, breaking the rules" if path and not s.view.verdict.ok else ""
                self._note(f"saved placement{anyway}: {path}" if path else "nothing placed: nothing to save")
            self._update_title()
        elif key == glfw.KEY_V:
            self.mode_3d = not self.mode_3d
            self._update_title()
        elif key == glfw.KEY_C:
            self.colour_by = "label" if self.colour_by == "rgb" else "rgb"
            self._build_geometry()
            self._update_title()
        elif key == glfw.KEY_X:
            path = Path(s.base.output) / "preview" / s.ident.split / s.ident.city / f"{s.ident.name}.ply"
            info = s.export_ply(path, self.colour_by)
            self._say(f"PLY written: {path} ({info['points']} points, {info['objects']} boxes)")
        elif key == glfw.KEY_H:
            self.show_help = not self.show_help
            if self.show_help:
                self._say(HELP)
        elif key == glfw.KEY_O:
            self.show_overlay = not self.show_overlay
        elif key == glfw.KEY_ESCAPE:
            glfw.set_window_should_close(self.window, True)
        self.dirty = True

    def on_mouse_button(self, window, button, action, mods) -> None:
        if action == self.glfw.PRESS:
            x, y = self.glfw.get_cursor_pos(window)
            self._drag = (button, x, y)
        else:
            self._drag = None

    def on_cursor(self, window, x, y) -> None:
        if self._drag is None or not self.mode_3d:
            return
        button, x0, y0 = self._drag
        dx, dy = x - x0, y - y0
        if button == self.glfw.MOUSE_BUTTON_LEFT:
            self.orbit.yaw -= dx * 0.01
            self.orbit.pitch = float(np.clip(self.orbit.pitch + dy * 0.01, -1.45, 1.45))
        else:
            self.orbit.pan(dx, dy)
        self._drag = (button, x, y)
        self.dirty = True

    def on_scroll(self, window, dx, dy) -> None:
        if self.mode_3d:
            self.orbit.distance = float(np.clip(self.orbit.distance * 0.9 ** dy, 0.5, 500.0))
            self.dirty = True

    # --------------------------------------------------------------------------- drawing
    def draw(self) -> None:
        import moderngl

        self.gl.activate()
        fw, fh = self.glfw.get_framebuffer_size(self.window)
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, fw, fh)
        if not self.mode_3d:
            self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
            self.ctx.clear(0.0, 0.0, 0.0, 1.0)
            self.image_tex.use(0)
            self.blit["u_image"].value = 0
            self.blit_vao.render(moderngl.TRIANGLES, vertices=3)
        else:
            self.ctx.clear(0.12, 0.12, 0.14, 1.0, depth=1.0)
            self.ctx.enable(moderngl.DEPTH_TEST | moderngl.PROGRAM_POINT_SIZE)
            self.points["u_mvp"].write(gl_mat4(self.orbit.matrix(fw / max(fh, 1))))
            for vao, mode, size, _ in self._geometry:
                self.points["u_point_size"].value = size
                vao.render(mode)
        if self.show_overlay:
            self._draw_overlay(fw, fh)
        self.dirty = False

    def _draw_overlay(self, fw: int, fh: int) -> None:
        """Blend the overlay's RGBA picture (made again only when its text or size changed) over the view."""
        import moderngl

        ov = self.overlay()
        if self._overlay_key != (fw, fh, ov):
            rgba = self.overlay_pixels = ov.render(fw, fh)
            self.overlay_tex = self._refill(self.overlay_tex, (fw, fh), 4, rgba)
            self._overlay_key = (fw, fh, ov)
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.overlay_tex.use(0)
        self.overlay_blit["u_image"].value = 0
        self.overlay_vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable(moderngl.BLEND)

    def read_framebuffer(self) -> np.ndarray:
        """(H, W, 3) uint8 RGB of the window's back buffer as just drawn (top row first)."""
        fw, fh = self.glfw.get_framebuffer_size(self.window)
        data = self.ctx.screen.read(viewport=(0, 0, fw, fh), components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(fh, fw, 3)[::-1].copy()

    def frame(self) -> None:
        """Draw if needed and show it."""
        if self.dirty:
            self.draw()
            self.glfw.swap_buffers(self.window)

    def run(self) -> None:
        self._say(HELP)
        glfw = self.glfw
        self.dirty = True
        while not glfw.window_should_close(self.window):
            glfw.wait_events_timeout(0.1)
            if self.dirty:
                self.frame()
        self.close()

    def close(self) -> None:
        if self.window is None:
            return
        self.session.close()
        self.gl.release()  # frees what the pipeline and this window made; the context itself is the window's
        self.glfw.destroy_window(self.window)
        self.glfw.terminate()
        self.window = None


def run_preview(manifest: Manifest, frame: str | None = None) -> int:
    PreviewWindow(manifest, frame).run()
    return 0
