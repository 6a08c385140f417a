// Homogeneous clipping of one triangle (refsoft/raster/_setup.py, spec section 2): Sutherland-
// Hodgman against the near plane, then the guard band's four side planes, in float64; each
// clip vertex carries its barycentrics with respect to the input triangle. Intersections are
// computed from the inside vertex towards the outside one.
const int N_PLANES = 5;
const int MAX_POLY = 8;

double plane_distance(dvec4 c, int plane, double gx, double gy) {
    precise double d;
    if (plane == 0) d = c.z + c.w;
    else if (plane == 1) d = gx * c.w - c.x;
    else if (plane == 2) d = gx * c.w + c.x;
    else if (plane == 3) d = gy * c.w - c.y;
    else d = gy * c.w + c.y;
    return d;
}

uint outcode(dvec4 c, double gx, double gy) {
    uint code = 0u;
    for (int p = 0; p < N_PLANES; p++) {
        if (plane_distance(c, p, gx, gy) < 0.0lf) code |= 1u << uint(p);
    }
    return code;
}

dvec4 poly_c[MAX_POLY];
dvec3 poly_b[MAX_POLY];

// Clips (c0, c1, c2) into poly_c / poly_b; returns the vertex count (0 when nothing is left).
int clip_polygon(dvec4 c0, dvec4 c1, dvec4 c2, double gx, double gy) {
    dvec4 tmp_c[MAX_POLY];
    dvec3 tmp_b[MAX_POLY];
    poly_c[0] = c0;
    poly_c[1] = c1;
    poly_c[2] = c2;
    poly_b[0] = dvec3(1.0lf, 0.0lf, 0.0lf);
    poly_b[1] = dvec3(0.0lf, 1.0lf, 0.0lf);
    poly_b[2] = dvec3(0.0lf, 0.0lf, 1.0lf);
    int n = 3;
    for (int plane = 0; plane < N_PLANES; plane++) {
        int m = 0;
        for (int i = 0; i < n; i++) {
            int j = (i + 1) % n;
            double di = plane_distance(poly_c[i], plane, gx, gy);
            double dj = plane_distance(poly_c[j], plane, gx, gy);
            if (di >= 0.0lf) {
                tmp_c[m] = poly_c[i];
                tmp_b[m] = poly_b[i];
                m++;
            }
            if ((di >= 0.0lf) != (dj >= 0.0lf)) {
                int a = di >= 0.0lf ? i : j;
                int b = di >= 0.0lf ? j : i;
                double da = di >= 0.0lf ? di : dj;
                double db = di >= 0.0lf ? dj : di;
                precise double t = da / (da - db);
                precise dvec4 cc;
                precise dvec3 bb;
                for (int k = 0; k < 4; k++) cc[k] = poly_c[a][k] + t * (poly_c[b][k] - poly_c[a][k]);
                for (int k = 0; k < 3; k++) bb[k] = poly_b[a][k] + t * (poly_b[b][k] - poly_b[a][k]);
                tmp_c[m] = cc;
                tmp_b[m] = bb;
                m++;
            }
        }
        n = m;
        for (int i = 0; i < n; i++) {
            poly_c[i] = tmp_c[i];
            poly_b[i] = tmp_b[i];
        }
        if (n < 3) return 0;
    }
    return n;
}
