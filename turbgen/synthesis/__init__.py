"""Field generators (no file I/O): they return or yield float32 arrays."""
