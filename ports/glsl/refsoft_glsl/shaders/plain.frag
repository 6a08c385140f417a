// The plain variant's fragments: MODE 0 (G-buffer) the interpolated world position (alpha 1:
// covered) and the renormalised normal; MODE 1 (main view) and 2 (virtual scene, on reflector
// k's stencil only) the shaded colour (spec section 5) and the object id.
layout(std430, binding = 0) readonly buffer Shading { float shading[]; };   // light, ambient, diffuse, background, colours

smooth in vec3 v_position;
smooth in vec3 v_normal;
flat in int v_object;

#if MODE == 0
layout(location = 0) out vec4 o_position;
layout(location = 1) out vec4 o_normal;
#else
layout(location = 0) out vec4 o_colour;
layout(location = 1) out int o_id;
#endif
#if MODE == 2
uniform isampler2D view_ids;
uniform int reflector;
#endif

void main() {
    vec3 n = length(v_normal) > 0.0 ? normalize(v_normal) : vec3(0.0);
#if MODE == 0
    o_position = vec4(v_position, 1.0);
    o_normal = vec4(n, 0.0);
#else
#if MODE == 2
    if (texelFetch(view_ids, ivec2(gl_FragCoord.xy), 0).r != reflector) discard;
#endif
    vec3 light = vec3(shading[0], shading[1], shading[2]);
    float k = shading[3] + shading[4] * abs(dot(n, light));
    int c = 8 + 3 * v_object;
    o_colour = vec4(vec3(shading[c], shading[c + 1], shading[c + 2]) * k, 1.0);
    o_id = v_object;
#endif
}
