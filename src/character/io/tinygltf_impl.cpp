// The tinygltf implementation, compiled into gatcore (Debian's libtinygltf-dev
// ships the header; building it here means the installed static library has
// no extra link-time dependency). Images are never decoded: no stb needed.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
