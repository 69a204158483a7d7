// bench_occt_depth's Open CASCADE side: read an IGES or STEP model (IGESControl_Reader,
// STEPControl_Reader), optionally sew it (BRepBuilderAPI_Sewing), mesh it with
// BRepMesh_IncrementalMesh at a linear deflection and return every face's triangles in world
// coordinates. A triangle is flagged when one of its seven sample points (centroid, edge
// midpoints, three interior points: bench_occt's measure) lies farther than the deflection from
// the nearest point of its face's surface (GeomAPI_ProjectPointOnSurf, tried only where the
// surface at the interpolated (u, v) is already farther): there the mesh breaks its own
// deflection. Uses Open CASCADE 7.6 (LGPL-2.1 with its exception) as a library only; optional,
// never a dependency of crisp. No exception leaves this file.
#include "occt_util.hpp"
#include "occt_tris.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <vector>

#include <BRepBndLib.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_Surface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <OSD_Parallel.hxx>
#include <OSD_ThreadPool.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Reader.hxx>
#include <Standard_Failure.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <gp_Pnt.hxx>
#include <gp_Pnt2d.hxx>

using occt_util::fail;
using occt_util::is_step;
using occt_util::kBary;

namespace
{

int mesh(const occt_tris_desc *d, occt_tris *r, char *err, size_t err_size)
{
    if (d->threads > 0) {
        OSD_Parallel::SetUseOcctThreads(Standard_True);
        OSD_ThreadPool::DefaultPool(d->threads);
    }
    TopoDS_Shape shape;
    if (is_step(d->path)) {
        STEPControl_Reader rd;
        if (rd.ReadFile(d->path) != IFSelect_RetDone) {
            fail(err, err_size, d->path, "STEPControl_Reader could not read the file");
            return 1;
        }
        rd.TransferRoots();
        shape = rd.OneShape();
    } else {
        IGESControl_Reader rd;
        if (rd.ReadFile(d->path) != IFSelect_RetDone) {
            fail(err, err_size, d->path, "IGESControl_Reader could not read the file");
            return 1;
        }
        rd.TransferRoots();
        shape = rd.OneShape();
    }
    if (shape.IsNull()) {
        fail(err, err_size, d->path, "the reader transferred no shape");
        return 1;
    }
    Bnd_Box box;
    BRepBndLib::Add(shape, box);
    if (box.IsVoid()) {
        fail(err, err_size, d->path, "the shape has an empty bounding box");
        return 1;
    }
    box.Get(r->box[0], r->box[1], r->box[2], r->box[3], r->box[4], r->box[5]);
    if (d->sew) {
        double diag = std::sqrt((r->box[3] - r->box[0]) * (r->box[3] - r->box[0]) +
                                (r->box[4] - r->box[1]) * (r->box[4] - r->box[1]) +
                                (r->box[5] - r->box[2]) * (r->box[5] - r->box[2]));
        BRepBuilderAPI_Sewing sewing(d->sew_rel_tol * diag);
        sewing.Add(shape);
        sewing.Perform();
        shape = sewing.SewedShape();
        if (shape.IsNull()) {
            fail(err, err_size, d->path, "sewing produced no shape");
            return 1;
        }
    }
    const double unit = d->unit_to_mm > 0 ? d->unit_to_mm : 1, defl = d->deflection * unit;
    BRepMesh_IncrementalMesh mesher(shape, defl, Standard_False, 0.5, Standard_True);
    if (!mesher.IsDone()) {
        fail(err, err_size, d->path, "BRepMesh_IncrementalMesh did not finish");
        return 1;
    }
    std::vector<double> pts;
    std::vector<unsigned char> off;
    for (TopExp_Explorer ex(shape, TopAbs_FACE); ex.More(); ex.Next()) {
        r->faces++;
        const TopoDS_Face &face = TopoDS::Face(ex.Current());
        TopLoc_Location tloc, sloc;
        Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, tloc);
        Handle(Geom_Surface) surf = BRep_Tool::Surface(face, sloc);
        if (tri.IsNull()) continue;
        r->faces_meshed++;
        const gp_Trsf tt = tloc.Transformation(), st = sloc.Transformation();
        GeomAPI_ProjectPointOnSurf nearest;
        bool nearest_ready = false;
        for (int t = 1; t <= tri->NbTriangles(); t++) {
            int n[3];
            tri->Triangle(t).Get(n[0], n[1], n[2]);
            gp_Pnt p[3];
            gp_Pnt2d uv[3];
            for (int i = 0; i < 3; i++) {
                p[i] = tri->Node(n[i]).Transformed(tt);
                if (tri->HasUVNodes()) uv[i] = tri->UVNode(n[i]);
                pts.push_back(p[i].X() / unit);
                pts.push_back(p[i].Y() / unit);
                pts.push_back(p[i].Z() / unit);
            }
            unsigned char bad = 0;
            for (int k = 0; k < 7 && !bad && !surf.IsNull(); k++) {
                const double *w = kBary[k];
                gp_Pnt q(w[0] * p[0].X() + w[1] * p[1].X() + w[2] * p[2].X(),
                         w[0] * p[0].Y() + w[1] * p[1].Y() + w[2] * p[2].Y(),
                         w[0] * p[0].Z() + w[1] * p[1].Z() + w[2] * p[2].Z());
                if (tri->HasUVNodes()) {
                    double u = w[0] * uv[0].X() + w[1] * uv[1].X() + w[2] * uv[2].X();
                    double v = w[0] * uv[0].Y() + w[1] * uv[1].Y() + w[2] * uv[2].Y();
                    if (q.Distance(surf->Value(u, v).Transformed(st)) <= defl) continue;
                }
                if (!nearest_ready) {
                    double u0, u1, v0, v1;
                    surf->Bounds(u0, u1, v0, v1);
                    nearest.Init(surf, u0, u1, v0, v1);
                    nearest_ready = true;
                }
                nearest.Perform(q.Transformed(st.Inverted()));
                if (nearest.NbPoints() > 0 && nearest.LowerDistance() > defl) bad = 1;
            }
            off.push_back(bad);
            r->off_count += bad;
        }
    }
    r->count = (long long)off.size();
    r->p = static_cast<double(*)[3][3]>(std::malloc(pts.size() * sizeof(double) + 1));
    r->off = static_cast<unsigned char *>(std::malloc(off.size() + 1));
    if (!r->p || !r->off) {
        fail(err, err_size, d->path, "out of memory for the triangles");
        return 1;
    }
    std::memcpy(r->p, pts.data(), pts.size() * sizeof(double));
    std::memcpy(r->off, off.data(), off.size());
    return 0;
}

} // namespace

extern "C" int occt_tris_mesh(const occt_tris_desc *desc, occt_tris *dest, char *err,
                              size_t err_size)
{
    std::memset(dest, 0, sizeof *dest);
    return occt_util::guarded(err, err_size, [&] { return mesh(desc, dest, err, err_size); });
}

extern "C" void occt_tris_free(occt_tris *t)
{
    std::free(t->p);
    std::free(t->off);
    t->p = nullptr;
    t->off = nullptr;
}
