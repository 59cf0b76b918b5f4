#pragma once
/// OpenGL 3.3 core entry points. On Linux, libglvnd's libGL exports every core function, so the
/// prototypes are enough and no loader is needed. Dear ImGui's OpenGL backend is compiled against
/// this header too (IMGUI_IMPL_OPENGL_LOADER_CUSTOM): the gl3w loader Debian's ImGui 1.86 ships
/// writes one pointer past its table (54 names, 53 slots), which UBSan rightly stops.
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES
#endif
#include <GL/gl.h>
#include <GL/glext.h>
