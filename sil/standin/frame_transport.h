/* The frame transport to the world (frame_transport.c): frames on stdin and stdout. */
#ifndef SIL_FRAME_TRANSPORT_H
#define SIL_FRAME_TRANSPORT_H

#include "world_interface.h"

/* The world as the model sees it, carried by frames. */
extern const struct sil_world sil_frame_world;

/* Say hello, then obey the world's set-up frames until its first run frame. */
void sil_frame_transport_start(void);

#endif
