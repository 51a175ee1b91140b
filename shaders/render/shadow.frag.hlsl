// Shadow maps keep depth only.
void main() {}
