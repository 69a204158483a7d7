// Surface pass, vertex stage: each leaf is one patch of one vertex; the vertex's index is the
// leaf's (within the bound range of the leaf buffer). gl_VertexID is used rather than the
// control stage's gl_PrimitiveID, which llvmpipe (Mesa 22.3) numbers wrongly for some patches.
uniform uint leaf_base;
out uint vs_leaf;

void main()
{
    vs_leaf = leaf_base + uint(gl_VertexID);
}
