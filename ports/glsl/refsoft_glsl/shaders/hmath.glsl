// The float32 transcendental functions of the hierarchy search, evaluated in float64 and rounded
// once (GLSL has no float64 atan; its float32 atan is not accurate enough). refsoft calls the
// host C library's atan2f and asinf, which are not correctly rounded: the two differ by one ULP
// in some arguments, which changes a containment test only when it is that close to its limit.
#if EXACT
const double D_PI = 3.141592653589793116lf;
const double D_HALF_PI = 1.570796326794896558lf;

// atan(t) for 0 <= t <= 1: two half-angle steps t -> t / (1 + sqrt(1 + t^2)) bring t below
// tan(pi/16), where the alternating series to t^25 is exact to float64 rounding.
double atan_unit(double t) {
    precise double a = t / (1.0lf + sqrt(1.0lf + t * t));
    precise double b = a / (1.0lf + sqrt(1.0lf + a * a));
    precise double b2 = b * b;
    precise double s = 0.0lf;
    for (int k = 12; k >= 0; k--) {
        s = (((k & 1) == 0 ? 1.0lf : -1.0lf) / double(2 * k + 1)) + b2 * s;
    }
    precise double r = 4.0lf * (b * s);
    return r;
}

// atan2(y, x) for y >= 0 (every call's y is a length), float32 arguments and result.
float atan2_f32(float y, float x) {
    double dy = double(y), ax = abs(double(x));
    bool negative = x < 0.0 || (x == 0.0 && (floatBitsToUint(x) >> 31) != 0u);
    precise double t;
    if (dy == 0.0lf && ax == 0.0lf) t = 0.0lf;
    else if (dy <= ax) t = atan_unit(dy / ax);
    else t = D_HALF_PI - atan_unit(ax / dy);
    precise double r = negative ? D_PI - t : t;
    return float(r);
}

// asin(x) for 0 <= x <= 1.
float asin_f32(float x) {
    double d = double(x);
    precise double c = sqrt((1.0lf - d) * (1.0lf + d));
    precise double t;
    if (c == 0.0lf) t = D_HALF_PI;
    else if (d <= c) t = atan_unit(d / c);
    else t = D_HALF_PI - atan_unit(c / d);
    return float(t);
}

float norm3(float x, float y, float z) {
    precise float n = sqrt((x * x + y * y) + z * z);
    return n;
}
#else
// the plain variant: GLSL's built-ins
const double D_PI = 3.141592653589793116lf;
float atan2_f32(float y, float x) { return atan(y, x); }
float asin_f32(float x) { return asin(x); }
float norm3(float x, float y, float z) { return length(vec3(x, y, z)); }
#endif
