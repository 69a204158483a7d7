/* crisp: every public header of the library, for programs that want all of it.
 *
 *   #include <crisp/crisp.h>      cc prog.c $(pkg-config --cflags --libs crisp)
 *
 * The quickest path from a file to a picture is crisp/app.h (open, frame, render, write); the
 * modules underneath are available one header each. crisp/osd.h (OpenSubdiv limit surfaces) is
 * left out: it exists only when crisp was built with CRISP_OSD. */
#ifndef CRISP_CRISP_H
#define CRISP_CRISP_H

#include "crisp/version.h"
#include "crisp/core.h"
#include "crisp/nurbs.h"
#include "crisp/model.h"
#include "crisp/construct.h"
#include "crisp/slefe.h"
#include "crisp/tess.h"
#include "crisp/trim.h"
#include "crisp/frep.h"
#include "crisp/frep_cell.h"
#include "crisp/render.h"
#include "crisp/plan.h"
#include "crisp/scene_file.h"
#include "crisp/io.h"
#include "crisp/image.h"
#include "crisp/app.h"

#endif
