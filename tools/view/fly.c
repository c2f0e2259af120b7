/* The viewer's fly camera: yaw and pitch about world y, WASD-style moves, mouse look. */
#include "view.h"

#include <math.h>

#define PITCH_LIMIT 1.55f /* just under 90 degrees: the basis stays defined */
#define MOUSE_RADIANS_PER_PIXEL 0.004f

static void forward_of(const view_fly *f, float d[3]) {
    d[0] = sinf(f->yaw) * cosf(f->pitch);
    d[1] = sinf(f->pitch);
    d[2] = cosf(f->yaw) * cosf(f->pitch);
}

void view_fly_from_camera(view_fly *f, const prt_camera *c, float diag) {
    float d[3], len = 0;
    for (int k = 0; k < 3; k++) d[k] = c->target[k] - c->eye[k], len += d[k] * d[k];
    len = sqrtf(len);
    if (!(len > 0)) d[0] = 0, d[1] = 0, d[2] = -1, len = 1;
    for (int k = 0; k < 3; k++) f->pos[k] = c->eye[k], d[k] /= len;
    f->yaw = atan2f(d[0], d[2]);
    f->pitch = asinf(fmaxf(-1.0f, fminf(1.0f, d[1])));
    f->speed = 0.25f * (diag > 0 ? diag : 1.0f);
    f->fov_y_deg = c->fov_y_deg;
}

void view_fly_camera(const view_fly *f, prt_camera *c) {
    float d[3];
    forward_of(f, d);
    for (int k = 0; k < 3; k++) c->eye[k] = f->pos[k], c->target[k] = f->pos[k] + d[k];
    c->up[0] = 0, c->up[1] = 1, c->up[2] = 0;
    c->fov_y_deg = f->fov_y_deg;
}

void view_fly_move(view_fly *f, float forward, float right, float up, float dt) {
    float d[3];
    forward_of(f, d);
    /* right = cross(forward, +y), as the renderer's image x axis. */
    float r[3] = {-d[2], 0, d[0]}, rl = sqrtf(r[0] * r[0] + r[2] * r[2]);
    if (rl > 0) r[0] /= rl, r[2] /= rl;
    float s = f->speed * dt;
    for (int k = 0; k < 3; k++) f->pos[k] += s * (forward * d[k] + right * r[k]);
    f->pos[1] += s * up;
}

void view_fly_look(view_fly *f, float dx, float dy) {
    /* Mouse right turns toward the image's right (-yaw: see forward_of and right above). */
    f->yaw -= dx * MOUSE_RADIANS_PER_PIXEL;
    f->pitch -= dy * MOUSE_RADIANS_PER_PIXEL;
    f->pitch = fmaxf(-PITCH_LIMIT, fminf(PITCH_LIMIT, f->pitch));
}
