/* `kincal export --c-header` through the C ABI: the exported initializer of the built-in ARIA
   (exported_aria.h, written by run.sh) compiles as strict C11, matches the library's struct
   size, and gives kincal_fk bit-identical to the library's own kincal_robot_aria. */
#include <stdio.h>
#include <string.h>

#include "exported_aria.h"

int main(void) {
    static const double qs[3][6] = {
        {0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        {0.3, -0.2, 0.5, 1.0, -0.7, 0.4},
        {-1.1, 1.3, -0.4, 2.0, 0.9, -2.5},
    };
    kincal_robot reference;
    size_t k;
    if (sizeof(kincal_robot) != kincal_robot_size()) {
        printf("sizeof(kincal_robot) differs from the library's\n");
        return 1;
    }
    if (kincal_robot_aria(&reference, KINCAL_ARIA_MODEL_NOMINAL, NULL) != KINCAL_STATUS_OK) {
        printf("kincal_robot_aria failed\n");
        return 1;
    }
    for (k = 0; k < 3; k++) {
        double got[16], want[16];
        if (kincal_fk(&exported_aria, qs[k], 6, NULL, got, 16, NULL) != KINCAL_STATUS_OK ||
            kincal_fk(&reference, qs[k], 6, NULL, want, 16, NULL) != KINCAL_STATUS_OK) {
            printf("kincal_fk failed at configuration %u\n", (unsigned)k);
            return 1;
        }
        if (memcmp(got, want, sizeof got) != 0) {
            printf("FK of the exported model differs at configuration %u\n", (unsigned)k);
            return 1;
        }
    }
    printf("exported model: FK bit-identical to kincal_robot_aria\n");
    return 0;
}
