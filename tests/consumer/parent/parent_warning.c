// SPDX-License-Identifier: MIT
/* Compiles with a warning under -Wall (an unused variable): it must build, somm's -Werror is somm's own. */
int main(void) {
  int unused;
  return 0;
}
