"""Commands that run, calibrate, record, simulate and check the sensor: `track`, `actuate`, `grasp`,
`record`, `recplot`, `states`, `live`, `closedloop`, `calibrate`, `classify`, `sim`, `doctor`."""
