/* Stand-in for the pico-sdk header of this name: everything is in sil_sdk.h. */
#include "sil_sdk.h"
