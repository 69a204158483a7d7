// bench_occt's Open CASCADE side: read an IGES model (IGESControl_Reader), optionally sew it
// (BRepBuilderAPI_Sewing), mesh it with BRepMesh_IncrementalMesh (parallel, OCCT's own thread
// pool) at a given linear deflection, and measure the mesh against the true surfaces on screen:
// for every triangle of every face, at seven barycentric points, the screen distance between the
// triangle's point and the face's surface evaluated at the triangle's interpolated (u, v)
// (Poly_Triangulation's UV nodes) -- the measure of crisp's surface-accuracy test
// (tests/render/test_cpu_render.c). Uses Open CASCADE 7.6 (LGPL-2.1 with its exception) as a
// library only; it is optional and never a dependency of crisp. No exception leaves this file.
#include "occt_util.hpp"
#include "occt_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <vector>

#include <BRepBndLib.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Geom_Surface.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <OSD_Parallel.hxx>
#include <OSD_ThreadPool.hxx>
#include <Poly_Triangulation.hxx>
#include <Standard_Failure.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <gp_Pnt.hxx>
#include <gp_Pnt2d.hxx>

using occt_util::fail;
using occt_util::kBary;

namespace
{

struct Projector {
    const occt_mesh_desc *d;
    // Pixel coordinates of p; false when p is not in front of the near plane.
    bool operator()(const gp_Pnt &p, double out[2]) const
    {
        const double(*m)[4] = d->view_proj;
        double c[4];
        for (int r = 0; r < 4; r++)
            c[r] = m[0][r] * p.X() + m[1][r] * p.Y() + m[2][r] * p.Z() + m[3][r];
        if (!(c[3] > d->znear)) return false;
        out[0] = (c[0] / c[3] + 1.0) * 0.5 * d->width;
        out[1] = (1.0 - c[1] / c[3]) * 0.5 * d->height;
        return true;
    }
};

double elapsed_ms(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b)
{
    return std::chrono::duration<double, std::milli>(b - a).count();
}

int measure(const occt_mesh_desc *d, occt_mesh_result *r, char *err, size_t err_size)
{
    *r = occt_mesh_result();
    if (d->threads > 0) {
        // Before any parallel work: the default pool is created once with this size.
        OSD_Parallel::SetUseOcctThreads(Standard_True);
        OSD_ThreadPool::DefaultPool(d->threads);
    }
    IGESControl_Reader reader;
    if (reader.ReadFile(d->path) != IFSelect_RetDone) {
        fail(err, err_size, d->path, "IGESControl_Reader could not read the file");
        return 1;
    }
    reader.TransferRoots();
    TopoDS_Shape shape = reader.OneShape();
    if (shape.IsNull()) {
        fail(err, err_size, d->path, "IGESControl_Reader transferred no shape");
        return 1;
    }
    Bnd_Box box;
    BRepBndLib::Add(shape, box);
    if (box.IsVoid()) {
        fail(err, err_size, d->path, "the shape has an empty bounding box");
        return 1;
    }
    double x0, y0, z0, x1, y1, z1;
    box.Get(x0, y0, z0, x1, y1, z1);
    if (d->sew) {
        double diag =
            std::sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0) + (z1 - z0) * (z1 - z0));
        BRepBuilderAPI_Sewing sewing(d->sew_rel_tol * diag);
        sewing.Add(shape);
        sewing.Perform();
        shape = sewing.SewedShape();
        if (shape.IsNull()) {
            fail(err, err_size, d->path, "sewing produced no shape");
            return 1;
        }
    }
    r->box[0] = x0, r->box[1] = y0, r->box[2] = z0, r->box[3] = x1, r->box[4] = y1, r->box[5] = z1;
    for (TopExp_Explorer ex(shape, TopAbs_FACE); ex.More(); ex.Next())
        r->faces++;

    const double ang = d->ang_deflection > 0 ? d->ang_deflection : 0.5;
    const int runs = d->runs > 0 ? d->runs : 1;
    std::vector<double> ms;
    for (int k = 0; k < runs; k++) {
        BRepTools::Clean(shape); // every run meshes from scratch
        auto a = std::chrono::steady_clock::now();
        BRepMesh_IncrementalMesh mesher(shape, d->deflection, Standard_False, ang, Standard_True);
        auto b = std::chrono::steady_clock::now();
        if (!mesher.IsDone()) {
            fail(err, err_size, d->path, "BRepMesh_IncrementalMesh did not finish");
            return 1;
        }
        ms.push_back(elapsed_ms(a, b));
    }
    std::sort(ms.begin(), ms.end());
    size_t n = ms.size();
    r->ms_median = n % 2 ? ms[n / 2] : 0.5 * (ms[n / 2 - 1] + ms[n / 2]);
    r->ms_min = ms.front();
    r->ms_max = ms.back();

    Projector project{d};
    for (TopExp_Explorer ex(shape, TopAbs_FACE); ex.More(); ex.Next()) {
        const TopoDS_Face &face = TopoDS::Face(ex.Current());
        TopLoc_Location tloc, sloc;
        Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, tloc);
        Handle(Geom_Surface) surf = BRep_Tool::Surface(face, sloc);
        if (tri.IsNull() || surf.IsNull() || !tri->HasUVNodes()) continue;
        r->faces_meshed++;
        r->triangles += tri->NbTriangles();
        r->occt_deflection = std::max(r->occt_deflection, tri->Deflection());
        const gp_Trsf tt = tloc.Transformation(), st = sloc.Transformation();
        // Samples over 0.5 px are measured again against the nearest point of the surface, to
        // tell a mesh that is off the surface from one whose (u, v) is off along it.
        GeomAPI_ProjectPointOnSurf nearest;
        bool nearest_ready = false;
        for (int t = 1; t <= tri->NbTriangles(); t++) {
            int n0, n1, n2;
            tri->Triangle(t).Get(n0, n1, n2);
            const int idx[3] = {n0, n1, n2};
            gp_Pnt p[3];
            gp_Pnt2d uv[3];
            for (int i = 0; i < 3; i++) {
                p[i] = tri->Node(idx[i]).Transformed(tt);
                uv[i] = tri->UVNode(idx[i]);
            }
            for (const auto &w : kBary) {
                gp_Pnt q(w[0] * p[0].X() + w[1] * p[1].X() + w[2] * p[2].X(),
                         w[0] * p[0].Y() + w[1] * p[1].Y() + w[2] * p[2].Y(),
                         w[0] * p[0].Z() + w[1] * p[1].Z() + w[2] * p[2].Z());
                double u = w[0] * uv[0].X() + w[1] * uv[1].X() + w[2] * uv[2].X();
                double v = w[0] * uv[0].Y() + w[1] * uv[1].Y() + w[2] * uv[2].Y();
                gp_Pnt s = surf->Value(u, v).Transformed(st);
                double a[2], b[2];
                if (!project(q, a) || !project(s, b)) continue;
                // Only what can be seen matters for a pixel bound (as in crisp's test).
                if (a[0] < -2 || a[1] < -2 || a[0] > d->width + 2 || a[1] > d->height + 2) continue;
                double dx = std::fabs(a[0] - b[0]), dy = std::fabs(a[1] - b[1]);
                r->worst_px = std::max(r->worst_px, std::max(dx, dy));
                r->worst_px_euclid = std::max(r->worst_px_euclid, std::sqrt(dx * dx + dy * dy));
                r->worst_3d = std::max(r->worst_3d, q.Distance(s));
                if (std::max(dx, dy) > 0.5) {
                    r->samples_over++;
                    if (!nearest_ready) {
                        double u0, u1, v0, v1;
                        surf->Bounds(u0, u1, v0, v1);
                        nearest.Init(surf, u0, u1, v0, v1);
                        nearest_ready = true;
                    }
                    nearest.Perform(q.Transformed(st.Inverted()));
                    double c[2];
                    if (nearest.NbPoints() > 0 &&
                        project(nearest.NearestPoint().Transformed(st), c)) {
                        double g = std::max(std::fabs(a[0] - c[0]), std::fabs(a[1] - c[1]));
                        r->worst_nearest_px = std::max(r->worst_nearest_px, g);
                        if (g > 0.5) r->samples_over_nearest++;
                    }
                }
                r->samples++;
            }
        }
    }
    return 0;
}

} // namespace

extern "C" int occt_mesh_measure(const occt_mesh_desc *desc, occt_mesh_result *dest, char *err,
                                 size_t err_size)
{
    return occt_util::guarded(err, err_size, [&] { return measure(desc, dest, err, err_size); });
}
