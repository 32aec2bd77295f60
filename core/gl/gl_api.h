// The one place that includes the OpenGL API: the 4.5 core-profile header with
// prototypes, resolved at link time against glvnd's libOpenGL (which exports
// every core entry point and dispatches to the current context's vendor).
// Include this instead of <GL/gl.h>.
#ifndef MVBRDF_CORE_GL_GL_API_H_
#define MVBRDF_CORE_GL_GL_API_H_

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>  // IWYU pragma: export

#endif  // MVBRDF_CORE_GL_GL_API_H_
