/* Unit test of fmu_uri_to_path: every resource-location form importers send (docs/fmi.md, "Resources"). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "uri.h"

static int failures = 0;

static void expect(const char* uri, const char* want) {
  char* got = fmu_uri_to_path(uri);
  int ok = (got == NULL && want == NULL) || (got && want && strcmp(got, want) == 0);
  if (!ok) {
    printf("FAIL %s: got %s, want %s\n", uri ? uri : "(NULL)", got ? got : "(NULL)", want ? want : "(NULL)");
    failures++;
  }
  free(got);
}

int main(void) {
  expect("file:///tmp/GearMesh/resources", "/tmp/GearMesh/resources/");
  expect("file:///tmp/GearMesh/resources/", "/tmp/GearMesh/resources/");
  expect("file:/tmp/r", "/tmp/r/");
  expect("file:/tmp/r/", "/tmp/r/");
  expect("file://localhost/tmp/r", "/tmp/r/");
  expect("FILE://LocalHost/tmp/r/", "/tmp/r/");
  expect("file:///", "/");
  expect("file:///tmp/a%20b/c%20d", "/tmp/a b/c d/");
  expect("file:///tmp/%C3%BCber/%e2%82%ac", "/tmp/\xc3\xbc" "ber/\xe2\x82\xac/");
  expect("file:///tmp/a%23b%25c", "/tmp/a#b%c/");
  expect("file:///tmp/%2541", "/tmp/%41/"); /* decoded once, not twice */
  expect("file:///tmp/unencoded space", "/tmp/unencoded space/");
  expect(NULL, NULL);
  expect("", NULL);
  expect("/tmp/r", NULL);
  expect("http://localhost/tmp/r", NULL);
  expect("file://server/share/r", NULL);
  expect("file://localhostx/tmp/r", NULL);
  expect("file://localhost", NULL);
  expect("file:relative/r", NULL);
  expect("file:///tmp/%2", NULL);
  expect("file:///tmp/%zz", NULL);
  expect("file:///tmp/a%00b", NULL);
  if (failures) return 1;
  printf("fmu_uri_to_path: all cases pass\n");
  return 0;
}
