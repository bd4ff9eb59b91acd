// Depth only (the skin seen from the key light).
void main() {
}
