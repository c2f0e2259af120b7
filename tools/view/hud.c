/* The viewer's overlay: lines of text on a translucent box, drawn with SDL's built-in
 * 8x8 test font (libSDL2_test) so the viewer needs no font files. */
#include "view.h"

#include <SDL_test_font.h>
#include <string.h>

void view_hud_draw(SDL_Renderer *r, const char *const *lines, int count, bool bottom) {
    int w = 0, h = count * FONT_LINE_HEIGHT + 8, win_w, win_h;
    for (int i = 0; i < count; i++) {
        int lw = (int)strlen(lines[i]) * FONT_CHARACTER_SIZE;
        w = lw > w ? lw : w;
    }
    SDL_GetRendererOutputSize(r, &win_w, &win_h);
    SDL_Rect box = {4, bottom ? win_h - h - 4 : 4, w + 12, h};
    SDL_SetRenderDrawBlendMode(r, SDL_BLENDMODE_BLEND);
    SDL_SetRenderDrawColor(r, 0, 0, 0, 160);
    SDL_RenderFillRect(r, &box);
    SDL_SetRenderDrawColor(r, 235, 235, 220, 255);
    for (int i = 0; i < count; i++) SDLTest_DrawString(r, box.x + 6, box.y + 5 + i * FONT_LINE_HEIGHT, lines[i]);
}
