// Issue 14, optional: Open CASCADE's BRepGProp on the bundled models, beside `crisp mass` (one-off
// measurement, not built by CMake; Debian 12 packages libocct-*-dev):
//   g++ -O2 -I/usr/include/opencascade bench/occt_gprop.cpp -o /tmp/occt_gprop -lTKSTEP -lTKIGES \
//       -lTKXSBase -lTKTopAlgo -lTKGeomAlgo -lTKBRep -lTKGeomBase -lTKG3d -lTKG2d -lTKMath
//       -lTKernel \ -lTKShHealing -lTKSTEPBase -lTKSTEPAttr -lTKSTEP209
//   /tmp/occt_gprop data/nurbs/occt_trj9_io1.stp
#include <BRepGProp.hxx>
#include <GProp_GProps.hxx>
#include <IGESControl_Reader.hxx>
#include <STEPControl_Reader.hxx>
#include <TopoDS_Shape.hxx>
#include <chrono>
#include <cstdio>
#include <cstring>

int main(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        const char *p = argv[i];
        size_t n = strlen(p);
        bool step = n > 4 && (!strcmp(p + n - 4, ".stp") || !strcmp(p + n - 5, ".step"));
        TopoDS_Shape s;
        if (step) {
            STEPControl_Reader r;
            if (r.ReadFile(p) != IFSelect_RetDone) continue;
            r.TransferRoots();
            s = r.OneShape();
        } else {
            IGESControl_Reader r;
            if (r.ReadFile(p) != IFSelect_RetDone) continue;
            r.TransferRoots();
            s = r.OneShape();
        }
        auto t0 = std::chrono::steady_clock::now();
        GProp_GProps v, a, v2, a2;
        BRepGProp::VolumeProperties(s, v);
        BRepGProp::SurfaceProperties(s, a);
        double eps = BRepGProp::VolumeProperties(s, v2, 1e-9); // adaptive, with its error
        double aeps = BRepGProp::SurfaceProperties(s, a2, 1e-9);
        double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        gp_Pnt c = v2.CentreOfMass();
        gp_Mat m = v2.MatrixOfInertia();
        printf("%s: area %.15g (adaptive %.15g, error %.2g) volume %.15g (adaptive %.15g, error "
               "%.2g)\n  adaptive centroid %.15g %.15g %.15g\n  inertia about the centroid "
               "(Ixx Iyy Izz Ixy Iyz Ixz) %.15g %.15g %.15g %.15g %.15g %.15g (%.3f s)\n",
               p, a.Mass(), a2.Mass(), aeps, v.Mass(), v2.Mass(), eps, c.X(), c.Y(), c.Z(), m(1, 1),
               m(2, 2), m(3, 3), m(1, 2), m(2, 3), m(1, 3), dt);
    }
    return 0;
}
