/**
 * @file dre.h
 * @brief libdrempower: DrEmpower / Daran Robot servo joint motors over CAN.
 *
 * Modules: dre_codec.h (frames), dre_params.h (parameter table),
 * dre_errors.h (error words), dre_framing.h (serial framings),
 * dre_client.h (motors, requests, multi-motor moves), dre_health.h (temperatures,
 * derating, errors and a heap-free supervisor step).
 */
#ifndef DRE_H
#define DRE_H

#include "dre_client.h"
#include "dre_codec.h"
#include "dre_errors.h"
#include "dre_framing.h"
#include "dre_health.h"
#include "dre_params.h"

#endif /* DRE_H */
