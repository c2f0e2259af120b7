/* packrt-view, the interactive viewer (SDL2): a fly camera over prt_render with adaptive
 * resolution while moving and refinement when still. fly.c holds the camera, hud.c the
 * overlay text, main.c the window, keys and frame loop. */
#ifndef PRT_TOOLS_VIEW_H
#define PRT_TOOLS_VIEW_H

#include "packrt.h"

#include <SDL.h>

/* A first-person camera: position, yaw about world +y and pitch, and a speed in world
 * units per second (scaled to the model so any mesh flies alike). */
typedef struct view_fly {
    float pos[3];
    float yaw, pitch; /* radians; yaw 0 looks along +z, pitch 0 is level */
    float speed;
    float fov_y_deg;
} view_fly;

/* Start from a camera (e.g. prt_camera_default) with a speed of a quarter of diag per second. */
void view_fly_from_camera(view_fly *f, const prt_camera *c, float diag);
/* The prt_camera the fly camera sees with (y up). */
void view_fly_camera(const view_fly *f, prt_camera *c);
/* Move along the view direction, to the right and up (world y) by the given amounts of
 * `speed x dt`. */
void view_fly_move(view_fly *f, float forward, float right, float up, float dt);
/* Turn by mouse movement in pixels (positive dx: to the right, dy: down). */
void view_fly_look(view_fly *f, float dx, float dy);

/* Lines of text in a translucent box at the top-left (or bottom-left when bottom) of the
 * window, with SDL's built-in 8x8 font. */
void view_hud_draw(SDL_Renderer *r, const char *const *lines, int count, bool bottom);

#endif
