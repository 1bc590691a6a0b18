/* ri.h — Obscura's RenderMan-compatible headers: the value types live in RixInterfaces.h. */
#include "RixInterfaces.h"
