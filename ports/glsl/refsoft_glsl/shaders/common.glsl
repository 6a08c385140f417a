// Shared by every compute shader: the invocation index over a 2-D dispatch, and the working
// precision REAL (float, or double when DOUBLE is 1).
layout(local_size_x = GROUP) in;

uint gid() {
    return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * uint(GROUP));
}

#ifndef DOUBLE
#define DOUBLE 0
#endif
#if DOUBLE
#define REAL double
#else
#define REAL float
#endif
