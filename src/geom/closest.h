/* Point queries on one triangle, in double precision: the closest point (Ericson, "Real-Time
 * Collision Detection", 2005, §5.1.5: the Voronoi region of the point decides the vertex,
 * edge or face), the squared distance from a point to a box, and the signed solid angle a
 * triangle subtends (Van Oosterom and Strackee 1983), the term of the generalized winding
 * number (Jacobson et al. 2013, eq. 6). */
#ifndef PRT_GEOM_CLOSEST_H
#define PRT_GEOM_CLOSEST_H

#include <math.h>

/* The point of triangle a, b, c nearest to p: returns the squared distance and sets its
 * barycentrics (u weights b, v weights c). Degenerate triangles give their nearest edge
 * or vertex point. */
static inline double prt__closest_on_triangle(const double p[3], const double a[3], const double b[3],
                                              const double c[3], double *u_out, double *v_out) {
    double ab[3], ac[3], ap[3];
    for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k];
#define DOT(x, y) ((x)[0] * (y)[0] + (x)[1] * (y)[1] + (x)[2] * (y)[2])
    double u, v;
    const double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
    double bp[3], cp[3];
    for (int k = 0; k < 3; k++) bp[k] = p[k] - b[k], cp[k] = p[k] - c[k];
    const double d3 = DOT(ab, bp), d4 = DOT(ac, bp), d5 = DOT(ab, cp), d6 = DOT(ac, cp);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d1 <= 0 && d2 <= 0) u = 0, v = 0;                              /* vertex a */
    else if (d3 >= 0 && d4 <= d3) u = 1, v = 0;                        /* vertex b */
    else if (d6 >= 0 && d5 <= d6) u = 0, v = 1;                        /* vertex c */
    else if (vc <= 0 && d1 >= 0 && d3 <= 0) u = d1 / (d1 - d3), v = 0; /* edge ab */
    else if (vb <= 0 && d2 >= 0 && d6 <= 0) u = 0, v = d2 / (d2 - d6); /* edge ac */
    else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) { /* edge bc */ v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        u = 1 - v;
    } else {
        const double den = va + vb + vc;
        if (den > 0) u = vb / den, v = vc / den;
        else u = 0, v = 0; /* a degenerate triangle the tests above did not place: vertex a */
    }
#undef DOT
    double d = 0;
    for (int k = 0; k < 3; k++) {
        const double q = a[k] + u * ab[k] + v * ac[k] - p[k];
        d += q * q;
    }
    *u_out = u, *v_out = v;
    return d;
}

/* Squared distance from p to the box lo xyz, hi xyz (0 inside). */
static inline double prt__box_distance2(const double p[3], const float box[6]) {
    double d = 0;
    for (int k = 0; k < 3; k++) {
        const double e = p[k] < box[k] ? box[k] - p[k] : p[k] > box[3 + k] ? p[k] - box[3 + k] : 0.0;
        d += e * e;
    }
    return d;
}

/* Signed solid angle of triangle a, b, c seen from p, in steradians: positive when p sees
 * the triangle's back (p is on the side its normal, (b - a) x (c - a), points away from). */
static inline double prt__solid_angle(const double p[3], const double a[3], const double b[3], const double c[3]) {
    double x[3], y[3], z[3];
    for (int k = 0; k < 3; k++) x[k] = a[k] - p[k], y[k] = b[k] - p[k], z[k] = c[k] - p[k];
    const double lx = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    const double ly = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    const double lz = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    const double det =
        x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0]) + x[2] * (y[0] * z[1] - y[1] * z[0]);
    const double xy = x[0] * y[0] + x[1] * y[1] + x[2] * y[2], yz = y[0] * z[0] + y[1] * z[1] + y[2] * z[2];
    const double zx = z[0] * x[0] + z[1] * x[1] + z[2] * x[2];
    return 2.0 * atan2(det, lx * ly * lz + xy * lz + yz * lx + zx * ly);
}

#endif
