// occt_faces FILE...: for each IGES or STEP file, the faces Open CASCADE's reader makes and the
// box of the shape (BRepBndLib), one tab-separated line per file:
//   path  faces  xmin ymin zmin xmax ymax zmax   (or: path  -1  error text)
// The Open CASCADE column of the face sweep (scripts/sweep-faces). Uses Open CASCADE 7.6
// (LGPL-2.1 with its exception) as a library only, built only where it is installed
// (scripts/setup-deps --with-occt). Faces are counted per occurrence (TopExp_Explorer), as
// crisp places one copy of a part's faces per use. No exception leaves this file.
#include "occt_util.hpp"
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <BRepBndLib.hxx>
#include <Bnd_Box.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <STEPControl_Reader.hxx>
#include <Standard_Failure.hxx>
#include <TopAbs_ShapeEnum.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS_Shape.hxx>

using occt_util::is_step;

namespace
{

void one(const char *path)
{
    try {
        TopoDS_Shape shape;
        if (is_step(path)) {
            STEPControl_Reader rd;
            if (rd.ReadFile(path) != IFSelect_RetDone) {
                std::printf("%s\t-1\tread failed\n", path);
                return;
            }
            rd.TransferRoots();
            shape = rd.OneShape();
        } else {
            IGESControl_Reader rd;
            if (rd.ReadFile(path) != IFSelect_RetDone) {
                std::printf("%s\t-1\tread failed\n", path);
                return;
            }
            rd.TransferRoots();
            shape = rd.OneShape();
        }
        long faces = 0;
        for (TopExp_Explorer ex(shape, TopAbs_FACE); ex.More(); ex.Next())
            faces++;
        Bnd_Box box;
        if (faces) BRepBndLib::Add(shape, box);
        double b[6] = {0, 0, 0, 0, 0, 0};
        if (faces && !box.IsVoid()) box.Get(b[0], b[1], b[2], b[3], b[4], b[5]);
        std::printf("%s\t%ld\t%.9g %.9g %.9g %.9g %.9g %.9g\n", path, faces, b[0], b[1], b[2], b[3],
                    b[4], b[5]);
    } catch (const Standard_Failure &e) {
        std::printf("%s\t-1\t%s\n", path, e.GetMessageString());
    } catch (const std::exception &e) {
        std::printf("%s\t-1\t%s\n", path, e.what());
    }
}

} // namespace

int main(int argc, char **argv)
{
    Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_Printer));
    for (int i = 1; i < argc; i++) {
        one(argv[i]);
        std::fflush(stdout);
    }
    return 0;
}
