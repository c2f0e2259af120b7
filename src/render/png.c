/* Image files: 8-bit RGB PNG through libpng when the build found it (PRT_HAVE_PNG), and
 * binary PPM, which needs nothing and is the fallback of builds without libpng. */
#include "core/common.h"
#include "io/atomic_file.h"

#include <errno.h>
#include <stdio.h>

#ifdef PRT_HAVE_PNG
#include <png.h>
#endif

static prt_status check_image(const prt_image *img, const char *path, const char *fn) {
    if (!img || !path || !img->rgb || !img->width || !img->height)
        return prt__fail(PRT_ERROR_ARGUMENT, "%s: NULL path or empty image", fn);
    return PRT_OK;
}

bool prt_image_png_supported(void) {
#ifdef PRT_HAVE_PNG
    return true;
#else
    return false;
#endif
}

prt_status prt_image_save_png(const prt_image *img, const char *path) {
    prt_status st = check_image(img, path, "prt_image_save_png");
    if (st) return st;
#ifdef PRT_HAVE_PNG
    /* libpng's simplified API: no setjmp error handling to get right, and it writes the
     * whole image from one buffer. sRGB is its default colour space for 8-bit data. */
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    pi.width = img->width;
    pi.height = img->height;
    pi.format = PNG_FORMAT_RGB;
    prt__afile a;
    if ((st = prt__afile_open(&a, path))) return st;
    if (!png_image_write_to_stdio(&pi, a.f, 0, img->rgb, (png_int_32)(3 * img->width), NULL)) {
        prt_status s = prt__fail(PRT_ERROR_IO, "%s: cannot write PNG: %s", path, pi.message);
        png_image_free(&pi);
        prt__afile_abort(&a);
        return s;
    }
    return prt__afile_commit(&a);
#else
    return prt__fail(PRT_ERROR_UNSUPPORTED,
                     "%s: this build of packrt has no libpng (install libpng-dev and reconfigure); "
                     "write a .ppm instead",
                     path);
#endif
}

prt_status prt_image_save_ppm(const prt_image *img, const char *path) {
    prt_status st = check_image(img, path, "prt_image_save_ppm");
    if (st) return st;
    prt__afile a;
    if ((st = prt__afile_open(&a, path))) return st;
    char head[64];
    int k = snprintf(head, sizeof head, "P6\n%u %u\n255\n", img->width, img->height);
    st = prt__afile_write(&a, head, (size_t)k);
    if (!st) st = prt__afile_write(&a, img->rgb, (size_t)img->width * img->height * 3);
    if (st) prt__afile_abort(&a);
    return st ? st : prt__afile_commit(&a);
}
