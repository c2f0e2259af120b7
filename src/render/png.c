/* Image files: 8-bit RGB PNG through libpng when the build found it (PRT_HAVE_PNG), and
 * binary PPM, which needs nothing and is the fallback of builds without libpng. */
#include "core/common.h"

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
    if (!png_image_write_to_file(&pi, path, 0, img->rgb, (png_int_32)(3 * img->width), NULL)) {
        prt_status s = prt__fail(PRT_ERROR_IO, "%s: cannot write PNG: %s", path, pi.message);
        png_image_free(&pi);
        return s;
    }
    return PRT_OK;
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
    FILE *f = fopen(path, "wb");
    if (!f)
        return prt__fail(PRT_ERROR_IO, "%s: cannot open for writing: %s", path, strerror(errno));
    size_t n = (size_t)img->width * img->height * 3;
    bool ok = fprintf(f, "P6\n%u %u\n255\n", img->width, img->height) > 0 &&
              fwrite(img->rgb, 1, n, f) == n;
    ok = (fclose(f) == 0) && ok;
    if (!ok) return prt__fail(PRT_ERROR_IO, "%s: write failed: %s", path, strerror(errno));
    return PRT_OK;
}
