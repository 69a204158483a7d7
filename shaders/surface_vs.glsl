// Surface pass, vertex stage: nothing to do; each leaf is one patch of one vertex and the
// tessellation stages fetch it by gl_PrimitiveID.
void main()
{
}
