/* The OpenSubdiv shim: a polygon cage -> Catmull-Clark limit surface as bicubic B-spline
 * patches. The only C++ in crisp. Every extern "C" entry point catches everything, so no
 * exception crosses into C. Recipe (OpenSubdiv 3.5 Far API and its tutorials):
 * TopologyDescriptor -> TopologyRefinerFactory (Catmull-Clark) -> RefineAdaptive ->
 * PatchTableFactory with ENDCAP_BSPLINE_BASIS (every patch REGULAR, 16 control vertices);
 * PrimvarRefiner::Interpolate level by level + ComputeLocalPointValues for the point buffer.
 *
 * A regular patch near a boundary is evaluated by OpenSubdiv with a boundary mask (implicit
 * phantom points), and its parameter box inside the ptex face comes from the PatchParam. Rather
 * than re-deriving those conventions, each patch is sampled with OpenSubdiv's own evaluation on a
 * 4 x 4 grid of its domain and the 16 B-spline control points that interpolate the samples are
 * solved for (the patch is a bicubic polynomial, so this reproduces it exactly up to rounding).
 */
#include "crisp/osd.h"

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <new>
#include <utility>
#include <vector>

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/ptexIndices.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

using namespace OpenSubdiv;

namespace
{

struct Point {
    double p[3];
    void Clear(void * = nullptr)
    {
        p[0] = p[1] = p[2] = 0.0;
    }
    void AddWithWeight(Point const &src, double w)
    {
        p[0] += w * src.p[0];
        p[1] += w * src.p[1];
        p[2] += w * src.p[2];
    }
};

struct PatchRecord {
    double cv[48]; /* 4 x 4 control points, u fastest */
    int base_face, ptex_face;
    double box[3];
};

/* OpenSubdiv reports topology errors through a callback; keep the last one for our message. */
thread_local char far_message[256];

void on_far_error(Far::ErrorType, const char *message)
{
    std::snprintf(far_message, sizeof far_message, "%s", message ? message : "");
}

void on_far_warning(const char *) {}

/* Uniform cubic B-spline basis on the span [0, 1] (knots ..., -1, 0, 1, 2, ...). */
void bspline_basis(double x, double b[4])
{
    double y = 1.0 - x;
    b[0] = y * y * y / 6.0;
    b[1] = (3.0 * x * x * x - 6.0 * x * x + 4.0) / 6.0;
    b[2] = (-3.0 * x * x * x + 3.0 * x * x + 3.0 * x + 1.0) / 6.0;
    b[3] = x * x * x / 6.0;
}

/* inv = A^-1 for A[a][i] = B_i(a / 3), by Gauss-Jordan with partial pivoting. */
void sample_matrix_inverse(double inv[4][4])
{
    double a[4][8];
    for (int r = 0; r < 4; r++) {
        double b[4];
        bspline_basis(r / 3.0, b);
        for (int c = 0; c < 4; c++) {
            a[r][c] = b[c];
            a[r][4 + c] = r == c ? 1.0 : 0.0;
        }
    }
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (std::fabs(a[r][c]) > std::fabs(a[piv][c])) piv = r;
        for (int k = 0; k < 8; k++)
            std::swap(a[c][k], a[piv][k]);
        double d = a[c][c];
        for (int k = 0; k < 8; k++)
            a[c][k] /= d;
        for (int r = 0; r < 4; r++) {
            if (r == c) continue;
            double f = a[r][c];
            for (int k = 0; k < 8; k++)
                a[r][k] -= f * a[c][k];
        }
    }
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            inv[r][c] = a[r][4 + c];
}

} // namespace

struct crisp_osd_mesh {
    Far::TopologyRefiner *refiner = nullptr;
    Far::PatchTable *table = nullptr;
    Far::PatchMap *map = nullptr;
    std::vector<Point> points; /* refined vertices, then local (end-cap) points */
    std::vector<Point> base;   /* the cage */
    std::vector<int> ptex_of_face, face_of_ptex;
    std::vector<PatchRecord> patches;
    int ptex_count = 0;

    ~crisp_osd_mesh()
    {
        delete map;
        delete table;
        delete refiner;
    }
};

static crisp_status validate(const crisp_osd_desc *d)
{
    if (d->vertex_count <= 0 || d->vertex_count > CRISP_OSD_MAX_ELEMENTS || !d->positions)
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: vertex count %d outside 1..%d",
                           d->vertex_count, CRISP_OSD_MAX_ELEMENTS);
    if (d->face_count <= 0 || d->face_count > CRISP_OSD_MAX_ELEMENTS || !d->face_sizes ||
        !d->face_vertices)
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: face count %d outside 1..%d", d->face_count,
                           CRISP_OSD_MAX_ELEMENTS);
    if (d->isolation < 0 || d->isolation > 10)
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: isolation level %d outside 1..10",
                           d->isolation);
    for (int i = 0; i < d->vertex_count * 3; i++)
        if (!std::isfinite(d->positions[i]))
            return crisp_error(CRISP_ERR_NUMERIC, "osd: vertex %d has a non-finite coordinate",
                               i / 3);
    long corners = 0;
    for (int f = 0; f < d->face_count; f++) {
        int n = d->face_sizes[f];
        if (n < 3 || n > 64)
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "osd: face %d has %d vertices (expected 3..64)", f, n);
        const int *fv = d->face_vertices + corners;
        for (int k = 0; k < n; k++) {
            if (fv[k] < 0 || fv[k] >= d->vertex_count)
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "osd: face %d refers to vertex %d (expected 0..%d)", f, fv[k],
                                   d->vertex_count - 1);
            for (int j = 0; j < k; j++)
                if (fv[j] == fv[k])
                    return crisp_error(CRISP_ERR_INVALID_ARG, "osd: face %d uses vertex %d twice",
                                       f, fv[k]);
        }
        corners += n;
        if (corners > CRISP_OSD_MAX_ELEMENTS)
            return crisp_error(CRISP_ERR_LIMIT, "osd: more than %d face corners",
                               CRISP_OSD_MAX_ELEMENTS);
    }
    return CRISP_OK;
}

/* Sample the patch with OpenSubdiv's basis on a 4 x 4 grid and solve for its control points. */
static crisp_status fit_patch(crisp_osd_mesh *m, const double inv[4][4], int array, int index,
                              PatchRecord *rec)
{
    Far::PatchParam param = m->table->GetPatchParam(array, index);
    Far::PatchDescriptor desc = m->table->GetPatchArrayDescriptor(array);
    if (desc.GetType() != Far::PatchDescriptor::REGULAR)
        return crisp_error(CRISP_ERR_INTERNAL, "osd: patch %d is not a regular B-spline patch",
                           index);
    /* The patch's box inside its ptex face: Unnormalize maps local (0,0) and (1,1) to it. */
    double u0 = 0, v0 = 0, u1 = 1, v1 = 1;
    param.Unnormalize(u0, v0);
    param.Unnormalize(u1, v1);
    int ptex = param.GetFaceId();
    Far::PatchTable::PatchHandle const *h =
        m->map->FindPatch(ptex, 0.5 * (u0 + u1), 0.5 * (v0 + v1));
    if (!h)
        return crisp_error(CRISP_ERR_INTERNAL, "osd: patch %d not found in its patch map", index);
    Far::ConstIndexArray cvs = m->table->GetPatchVertices(*h);
    double samples[4][4][3]; /* [row b (v)][column a (u)] */
    for (int b = 0; b < 4; b++)
        for (int a = 0; a < 4; a++) {
            double w[20];
            double u = u0 + (u1 - u0) * a / 3.0, v = v0 + (v1 - v0) * b / 3.0;
            m->table->EvaluateBasis(*h, u, v, w);
            double p[3] = {0, 0, 0};
            for (int k = 0; k < cvs.size(); k++)
                for (int c = 0; c < 3; c++)
                    p[c] += w[k] * m->points[cvs[k]].p[c];
            for (int c = 0; c < 3; c++)
                samples[b][a][c] = p[c];
        }
    /* C = A^-1 S A^-T per coordinate (S[b][a] sampled at u = a/3, v = b/3). */
    double tmp[4][4][3];
    for (int b = 0; b < 4; b++)
        for (int i = 0; i < 4; i++)
            for (int c = 0; c < 3; c++) {
                double s = 0;
                for (int a = 0; a < 4; a++)
                    s += inv[i][a] * samples[b][a][c];
                tmp[b][i][c] = s;
            }
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int c = 0; c < 3; c++) {
                double s = 0;
                for (int b = 0; b < 4; b++)
                    s += inv[j][b] * tmp[b][i][c];
                rec->cv[(j * 4 + i) * 3 + c] = s;
            }
    rec->ptex_face = ptex;
    rec->base_face = ptex >= 0 && ptex < (int)m->face_of_ptex.size() ? m->face_of_ptex[ptex] : -1;
    rec->box[0] = u0;
    rec->box[1] = v0;
    rec->box[2] = u1 - u0;
    return CRISP_OK;
}

static crisp_status build(const crisp_osd_desc *d, crisp_osd_mesh *m)
{
    Far::SetErrorCallback(on_far_error);
    Far::SetWarningCallback(on_far_warning);
    far_message[0] = '\0';

    Far::TopologyDescriptor td;
    td.numVertices = d->vertex_count;
    td.numFaces = d->face_count;
    td.numVertsPerFace = d->face_sizes;
    td.vertIndicesPerFace = d->face_vertices;

    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    sdc.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_NONE);
    typedef Far::TopologyRefinerFactory<Far::TopologyDescriptor> Factory;
    m->refiner = Factory::Create(td, Factory::Options(Sdc::SCHEME_CATMARK, sdc));
    if (!m->refiner)
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: OpenSubdiv rejected the topology: %s",
                           far_message[0] ? far_message : "(no message)");

    m->base.resize(d->vertex_count);
    for (int i = 0; i < d->vertex_count; i++)
        for (int c = 0; c < 3; c++)
            m->base[i].p[c] = d->positions[i * 3 + c];

    Far::PtexIndices ptex(*m->refiner);
    m->ptex_count = ptex.GetNumFaces();
    m->ptex_of_face.resize(d->face_count);
    m->face_of_ptex.assign(m->ptex_count, -1);
    for (int f = 0; f < d->face_count; f++) {
        int first = ptex.GetFaceId(f);
        m->ptex_of_face[f] = first;
        int n = d->face_sizes[f] == 4 ? 1 : d->face_sizes[f];
        for (int k = 0; k < n && first + k < m->ptex_count; k++)
            m->face_of_ptex[first + k] = f;
    }

    int isolation = d->isolation ? d->isolation : CRISP_OSD_DEFAULT_ISOLATION;
    Far::PatchTableFactory::Options po(isolation);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_BSPLINE_BASIS);
    po.SetPatchPrecision<double>();
    m->refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
    m->table = Far::PatchTableFactory::Create(*m->refiner, po);
    if (!m->table)
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: no patch table: %s",
                           far_message[0] ? far_message : "(no message)");

    int nref = m->refiner->GetNumVerticesTotal();
    int nlocal = m->table->GetNumLocalPoints();
    m->points.resize((size_t)nref + (size_t)nlocal);
    std::copy(m->base.begin(), m->base.end(), m->points.begin());
    Far::PrimvarRefinerReal<double> primvar(*m->refiner);
    Point *src = m->points.data();
    for (int level = 1; level <= m->refiner->GetMaxLevel(); level++) {
        Point *dst = src + m->refiner->GetLevel(level - 1).GetNumVertices();
        primvar.Interpolate(level, src, dst);
        src = dst;
    }
    /* ComputeLocalPointValues assumes float stencils; the table was built in double, so apply
     * the double stencil table directly. */
    Far::StencilTableReal<double> const *local = m->table->GetLocalPointStencilTable<double>();
    if (nlocal > 0 && local) local->UpdateValues(m->points.data(), m->points.data() + nref);

    m->map = new Far::PatchMap(*m->table);

    double inv[4][4];
    sample_matrix_inverse(inv);
    m->patches.resize(m->table->GetNumPatchesTotal());
    int k = 0;
    for (int a = 0; a < m->table->GetNumPatchArrays(); a++)
        for (int i = 0; i < m->table->GetNumPatches(a); i++, k++) {
            crisp_status st = fit_patch(m, inv, a, i, &m->patches[k]);
            if (st != CRISP_OK) return st;
        }
    return CRISP_OK;
}

extern "C" crisp_status crisp_osd_mesh_create(const crisp_osd_desc *desc, crisp_osd_mesh **dest)
{
    if (!desc || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "osd: NULL argument");
    *dest = nullptr;
    crisp_status st = validate(desc);
    if (st != CRISP_OK) return st;
    crisp_osd_mesh *m = nullptr;
    try {
        m = new crisp_osd_mesh();
        st = build(desc, m);
    } catch (std::bad_alloc const &) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "osd: out of memory refining the mesh");
    } catch (...) {
        st = crisp_error(CRISP_ERR_INTERNAL, "osd: OpenSubdiv threw an exception");
    }
    if (st != CRISP_OK) {
        delete m;
        return st;
    }
    *dest = m;
    return CRISP_OK;
}

extern "C" void crisp_osd_mesh_destroy(crisp_osd_mesh *m)
{
    try {
        delete m;
    } catch (...) {
    }
}

extern "C" int crisp_osd_mesh_patch_count(const crisp_osd_mesh *m)
{
    return m ? (int)m->patches.size() : 0;
}

extern "C" crisp_status crisp_osd_mesh_patch_surface(const crisp_osd_mesh *m, int patch,
                                                     crisp_surface **dest)
{
    if (!m || patch < 0 || patch >= (int)m->patches.size())
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: no patch %d", patch);
    static const double knots[8] = {-3, -2, -1, 0, 1, 2, 3, 4};
    return crisp_surface_create(3, 3, 4, 4, knots, knots, m->patches[patch].cv, NULL, dest);
}

extern "C" void crisp_osd_mesh_patch_points(const crisp_osd_mesh *m, int patch, double dest[48])
{
    if (!m || patch < 0 || patch >= (int)m->patches.size()) return;
    std::memcpy(dest, m->patches[patch].cv, sizeof m->patches[patch].cv);
}

extern "C" void crisp_osd_mesh_patch_info(const crisp_osd_mesh *m, int patch, int *base_face,
                                          int *ptex_face, double box[3])
{
    if (!m || patch < 0 || patch >= (int)m->patches.size()) return;
    const PatchRecord &r = m->patches[patch];
    if (base_face) *base_face = r.base_face;
    if (ptex_face) *ptex_face = r.ptex_face;
    if (box) std::memcpy(box, r.box, sizeof r.box);
}

extern "C" int crisp_osd_mesh_ptex_count(const crisp_osd_mesh *m)
{
    return m ? m->ptex_count : 0;
}

extern "C" int crisp_osd_mesh_ptex_of_face(const crisp_osd_mesh *m, int face)
{
    if (!m || face < 0 || face >= (int)m->ptex_of_face.size()) return -1;
    return m->ptex_of_face[face];
}

extern "C" crisp_status crisp_osd_mesh_eval(const crisp_osd_mesh *m, int ptex_face, double u,
                                            double v, double dest[3])
{
    if (!m || ptex_face < 0 || ptex_face >= m->ptex_count || !(u >= 0 && u <= 1) ||
        !(v >= 0 && v <= 1))
        return crisp_error(CRISP_ERR_INVALID_ARG, "osd: no point (%g, %g) on ptex face %d", u, v,
                           ptex_face);
    try {
        Far::PatchTable::PatchHandle const *h = m->map->FindPatch(ptex_face, u, v);
        if (!h)
            return crisp_error(CRISP_ERR_INVALID_ARG, "osd: ptex face %d has no patch at (%g, %g)",
                               ptex_face, u, v);
        Far::ConstIndexArray cvs = m->table->GetPatchVertices(*h);
        double w[20];
        m->table->EvaluateBasis(*h, u, v, w);
        dest[0] = dest[1] = dest[2] = 0;
        for (int k = 0; k < cvs.size(); k++)
            for (int c = 0; c < 3; c++)
                dest[c] += w[k] * m->points[cvs[k]].p[c];
    } catch (...) {
        return crisp_error(CRISP_ERR_INTERNAL, "osd: OpenSubdiv threw an exception");
    }
    return CRISP_OK;
}

extern "C" crisp_status crisp_osd_mesh_limit_vertices(const crisp_osd_mesh *m, double *dest)
{
    if (!m || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "osd: NULL argument");
    Far::TopologyRefiner *base = nullptr;
    crisp_status st = CRISP_OK;
    try {
        /* Limit needs a last level with full topology: an unrefined copy of the base level. */
        base = Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Create(*m->refiner);
        std::vector<Point> out(m->base.size());
        Far::PrimvarRefinerReal<double> primvar(*base);
        const Point *src = m->base.data();
        Point *dst = out.data();
        primvar.Limit(src, dst);
        for (size_t i = 0; i < out.size(); i++)
            for (int c = 0; c < 3; c++)
                dest[i * 3 + c] = out[i].p[c];
    } catch (std::bad_alloc const &) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "osd: out of memory");
    } catch (...) {
        st = crisp_error(CRISP_ERR_INTERNAL, "osd: OpenSubdiv threw an exception");
    }
    delete base;
    return st;
}
