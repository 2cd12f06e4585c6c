// The header-only parsers' code, compiled into the fuzz build (the product links Debian's shared
// builds of the same headers). Images are never decoded: the glTF reader installs its own no-op
// image loader, so stb_image is left out here.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>

#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
