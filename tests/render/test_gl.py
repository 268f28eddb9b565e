"""The GL context owner: waiting for queued GL work lets other Python threads run."""
import threading
import time

import moderngl
import numpy as np

from ..tolerances import GL_LONG_WAIT_S, GL_WAIT_COUNT_PERIOD_S

_SLOW = """
#version 330 core
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#else
out vec4 colour;
uniform int u_loops;
void main() {
    vec2 z = gl_FragCoord.xy / 1024.0;
    for (int i = 0; i < u_loops; ++i) z = vec2(z.x * z.x - z.y * z.y, 2.0 * z.x * z.y) + vec2(0.3, 0.5);
    colour = vec4(z, 0.0, 1.0);
}
#endif
"""


def test_wait_lets_other_threads_run(gl_clean):
    """moderngl holds Python's GIL through every call, the ones that wait for the GL included;
    GLContext.wait() waits without it, so Pipeline.stream's reading and writing threads run
    while the GL thread waits. A thread counting in Python goes on counting during wait()."""
    gl = gl_clean
    ctx = gl.ctx
    src = lambda stage: _SLOW.replace("#version 330 core", f"#version 330 core\n#define {stage} 1")  # noqa: E731
    prog = ctx.program(vertex_shader=src("VERTEX_SHADER"), fragment_shader=src("FRAGMENT_SHADER"))
    prog["u_loops"].value = 200
    vao = ctx.vertex_array(prog, [])
    target = ctx.texture((512, 512), 4, dtype="f4")
    fbo = ctx.framebuffer([target])
    count, stop = [0], threading.Event()

    def counter() -> None:  # needs the GIL for a moment every millisecond
        while not stop.is_set():
            time.sleep(0.001)
            count[0] += 1

    thread = threading.Thread(target=counter)
    thread.start()
    try:
        fbo.use()
        during = []
        for _ in range(3):  # the wait is long enough to count in (llvmpipe: tens of ms)
            for _ in range(8):
                vao.render(moderngl.TRIANGLES, vertices=3)
            before = count[0]
            t0 = time.perf_counter()
            gl.wait()
            waited = time.perf_counter() - t0
            during.append((count[0] - before, waited))
        values = np.frombuffer(target.read(), np.float32)
        assert np.isfinite(values).any()
    finally:
        stop.set()
        thread.join()
        for obj in (fbo, target, vao, prog):
            gl.free(obj)  # the framebuffer unbound first
    # holding the GIL, the counter would get in once or twice per wait; without it, about once a
    # millisecond: at least once per 10 ms is asked for (a fast GPU may finish too soon to tell)
    long_waits = [(n, waited) for n, waited in during if waited > GL_LONG_WAIT_S]
    if long_waits:
        assert max(n / (waited / GL_WAIT_COUNT_PERIOD_S) for n, waited in long_waits) >= 1.0, during
