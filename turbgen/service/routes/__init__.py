"""The routers of `turbgen serve`: runs, sweeps, derived products (exports, validation, lidar), pages and health."""
