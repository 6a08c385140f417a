// The plain variant's raster (refsoft_glsl/plain.py): GL transforms float32 world vertices by the
// float32 view-projection matrix, clips, rasterizes and interpolates (``smooth``).
uniform mat4 view_proj;

in vec3 in_position;
in vec3 in_normal;
in int in_object;

smooth out vec3 v_position;
smooth out vec3 v_normal;
flat out int v_object;

void main() {
    gl_Position = view_proj * vec4(in_position, 1.0);
    v_position = in_position;
    v_normal = in_normal;
    v_object = in_object;
}
