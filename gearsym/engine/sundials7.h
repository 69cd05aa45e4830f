/*
 * sundials7.h -- gearsym's own declarations of the SUNDIALS 7 functions and
 * constants used by gs_driver.c.
 *
 * Why: the scikit-sundae wheel ships SUNDIALS 7.9 shared libraries
 * (scikit_sundae.libs/libsundials_*.so) but no headers.  The driver links those
 * libraries by path and declares the small API subset it needs here.  Only the
 * documented public API is used; all SUNDIALS objects are opaque pointers, with
 * ONE exception checked at load time by gs_check_abi(): the leading members of
 * the dense SUNMatrix content struct, used to verify that sunindextype is int32.
 *
 * Build assumptions (checked at run time by gs_check_abi):
 *   SUNDIALS major version >= 7, sunrealtype = double, sunindextype = int32_t,
 *   no MPI (SUNComm = int).
 *
 * Sources of every block (LLNL/sundials, v7.x, include/...):
 *   sundials/sundials_types.h   sunrealtype, sunindextype, sunbooleantype,
 *                               SUNErrCode, SUNComm, SUN_COMM_NULL, opaque types,
 *                               SUNErrHandlerFn
 *   sundials/sundials_errors.h  SUN_SUCCESS
 *   sundials/sundials_context.h SUNContext_* functions
 *   sundials/sundials_logger.h  SUNLogger, SUNLogger_Set*File
 *   sundials/sundials_version.h SUNDIALSGetVersion, SUNDIALSGetVersionNumber
 *   sundials/sundials_nvector.h, nvector/nvector_serial.h
 *   sundials/sundials_matrix.h, sunmatrix/sunmatrix_dense.h
 *   sundials/sundials_linearsolver.h, sunlinsol/sunlinsol_dense.h
 *   cvode/cvode.h, cvode/cvode_ls.h
 *   ida/ida.h, ida/ida_ls.h
 * Cross-checked against the Cython declarations shipped in the scikit-sundae
 * 1.2.0 wheel (sksundae/c_*.pxd, c_config.pxi: sunrealtype double,
 * sunindextype int) and the symbols exported by its libsundials_*.so.7.9.0.
 */
#ifndef GS_SUNDIALS7_H
#define GS_SUNDIALS7_H

#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- sundials/sundials_types.h (v7): scalar types ---------------------- */
typedef double  sunrealtype;     /* SUNDIALS_DOUBLE_PRECISION build          */
typedef int32_t sunindextype;    /* SUNDIALS_INDEX_SIZE=32 (scikit-sundae)    */
typedef int     sunbooleantype;
typedef int     SUNErrCode;
typedef int     SUNComm;         /* non-MPI build: typedef int SUNComm        */
#define SUN_COMM_NULL 0          /* non-MPI build: #define SUN_COMM_NULL 0     */
#define SUNFALSE 0
#define SUNTRUE  1

/* ---- opaque object types (sundials_types.h / *_nvector.h / *_matrix.h) -- */
typedef struct SUNContext_*               SUNContext;
typedef struct _generic_N_Vector*         N_Vector;
typedef struct _generic_SUNMatrix*        SUNMatrix;
typedef struct _generic_SUNLinearSolver*  SUNLinearSolver;

/* ---- sundials/sundials_types.h (v7): error handler type ----------------- */
typedef void (*SUNErrHandlerFn)(int line, const char* func, const char* file,
                                const char* msg, SUNErrCode err_code,
                                void* err_user_data, SUNContext sunctx);

/* ---- sundials/sundials_errors.h (v7) ------------------------------------ */
#define SUN_SUCCESS 0
const char* SUNGetErrMsg(SUNErrCode code);

/* ---- sundials/sundials_context.h (v7) ----------------------------------- */
SUNErrCode SUNContext_Create(SUNComm comm, SUNContext* sunctx_out);
SUNErrCode SUNContext_Free(SUNContext* ctx);
SUNErrCode SUNContext_PushErrHandler(SUNContext sunctx, SUNErrHandlerFn err_fn,
                                     void* err_user_data);
SUNErrCode SUNContext_ClearErrHandlers(SUNContext sunctx);
SUNErrCode SUNContext_GetLastError(SUNContext sunctx);

/* ---- sundials/sundials_logger.h (v7; the *_File setters exist in 7.9) ----
 * Used to keep SUNDIALS warnings off stdout/stderr (the wheel's build prints
 * them to stdout); a NULL FILE* disables a stream. */
typedef struct SUNLogger_* SUNLogger;
SUNErrCode SUNContext_GetLogger(SUNContext sunctx, SUNLogger* logger);
SUNErrCode SUNLogger_SetErrorFile(SUNLogger logger, FILE* error_fp);
SUNErrCode SUNLogger_SetWarningFile(SUNLogger logger, FILE* warning_fp);
SUNErrCode SUNLogger_SetInfoFile(SUNLogger logger, FILE* info_fp);
SUNErrCode SUNLogger_SetDebugFile(SUNLogger logger, FILE* debug_fp);

/* ---- sundials/sundials_version.h ---------------------------------------- */
int SUNDIALSGetVersion(char* version, int len);
int SUNDIALSGetVersionNumber(int* major, int* minor, int* patch, char* label,
                             int len);

/* ---- sundials/sundials_nvector.h, nvector/nvector_serial.h (v7) -------- */
N_Vector     N_VNew_Serial(sunindextype vec_length, SUNContext sunctx);
void         N_VDestroy(N_Vector v);
sunrealtype* N_VGetArrayPointer(N_Vector v);
void         N_VConst(sunrealtype c, N_Vector z);

/* ---- sundials/sundials_matrix.h, sunmatrix/sunmatrix_dense.h (v7) ------ */
SUNMatrix    SUNDenseMatrix(sunindextype M, sunindextype N, SUNContext sunctx);
sunrealtype* SUNDenseMatrix_Data(SUNMatrix A);   /* column-major, ld = M   */
void         SUNMatDestroy(SUNMatrix A);
/* Layout facts used ONLY by gs_check_abi (sundials_matrix.h /
 * sunmatrix_dense.h): struct _generic_SUNMatrix { void* content; ... } and
 * struct _SUNMatrixContent_Dense { sunindextype M; sunindextype N;
 * sunrealtype* data; sunindextype ldata; sunrealtype** cols; }.            */

/* ---- sundials/sundials_linearsolver.h, sunlinsol/sunlinsol_dense.h ------ */
SUNLinearSolver SUNLinSol_Dense(N_Vector y, SUNMatrix A, SUNContext sunctx);
SUNErrCode      SUNLinSolFree(SUNLinearSolver S);
sunindextype    SUNDenseMatrix_Rows(SUNMatrix A);

/* A custom linear solver (the block-diagonal solver of the variational
 * equations) fills the operations table of a SUNLinearSolver made by
 * SUNLinSolNewEmpty.  Layout of struct _generic_SUNLinearSolver_Ops and
 * _generic_SUNLinearSolver as in sundials_linearsolver.h of SUNDIALS 7.9 (with
 * `setoptions`, 16 slots); enum return types are int-sized.  gs_check_abi verifies the
 * table slot by slot (each public SUNLinSol* wrapper must reach its own slot)
 * before any solver uses it. */
#define GS_SUNLINEARSOLVER_DIRECT 0
#define GS_SUNLINEARSOLVER_CUSTOM 17
#define GS_SUNLS_LUFACT_FAIL 808 /* recoverable: singular matrix */
struct _generic_SUNLinearSolver_Ops {
  int (*gettype)(SUNLinearSolver);
  int (*getid)(SUNLinearSolver);
  SUNErrCode (*setatimes)(SUNLinearSolver, void*, void*);
  SUNErrCode (*setpreconditioner)(SUNLinearSolver, void*, void*, void*);
  SUNErrCode (*setscalingvectors)(SUNLinearSolver, N_Vector, N_Vector);
  SUNErrCode (*setoptions)(SUNLinearSolver, const char*, const char*, int, char**);
  SUNErrCode (*setzeroguess)(SUNLinearSolver, sunbooleantype);
  SUNErrCode (*initialize)(SUNLinearSolver);
  int (*setup)(SUNLinearSolver, SUNMatrix);
  int (*solve)(SUNLinearSolver, SUNMatrix, N_Vector, N_Vector, sunrealtype);
  int (*numiters)(SUNLinearSolver);
  sunrealtype (*resnorm)(SUNLinearSolver);
  sunindextype (*lastflag)(SUNLinearSolver);
  SUNErrCode (*space)(SUNLinearSolver, long int*, long int*);
  N_Vector (*resid)(SUNLinearSolver);
  SUNErrCode (*free)(SUNLinearSolver);
};
struct _generic_SUNLinearSolver {
  void* content;
  void* python; /* 7.9 (read off the wheel's SUNLinSolNewEmpty: ops at offset 16,
                 * 32-byte object): the Python-bindings slot of recent 7.x */
  struct _generic_SUNLinearSolver_Ops* ops;
  SUNContext sunctx;
};
SUNLinearSolver SUNLinSolNewEmpty(SUNContext sunctx);
void            SUNLinSolFreeEmpty(SUNLinearSolver S);
int             SUNLinSolGetType(SUNLinearSolver S);
int             SUNLinSolGetID(SUNLinearSolver S);
SUNErrCode      SUNLinSolSetScalingVectors(SUNLinearSolver S, N_Vector s1, N_Vector s2);
SUNErrCode      SUNLinSolSetZeroGuess(SUNLinearSolver S, sunbooleantype onoff);
SUNErrCode      SUNLinSolInitialize(SUNLinearSolver S);
int             SUNLinSolSetup(SUNLinearSolver S, SUNMatrix A);
int             SUNLinSolSolve(SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, sunrealtype tol);
int             SUNLinSolNumIters(SUNLinearSolver S);
sunrealtype     SUNLinSolResNorm(SUNLinearSolver S);
sunindextype    SUNLinSolLastFlag(SUNLinearSolver S);
N_Vector        SUNLinSolResid(SUNLinearSolver S);

/* ---- cvode/cvode.h (v7) -------------------------------------------------- */
#define CV_ADAMS 1
#define CV_BDF   2

#define CV_NORMAL   1
#define CV_ONE_STEP 2

#define CV_SUCCESS       0
#define CV_TSTOP_RETURN  1
#define CV_ROOT_RETURN   2
#define CV_WARNING      99

#define CV_TOO_MUCH_WORK     -1
#define CV_TOO_MUCH_ACC      -2
#define CV_ERR_FAILURE       -3
#define CV_CONV_FAILURE      -4
#define CV_LINIT_FAIL        -5
#define CV_LSETUP_FAIL       -6
#define CV_LSOLVE_FAIL       -7
#define CV_RHSFUNC_FAIL      -8
#define CV_FIRST_RHSFUNC_ERR -9
#define CV_REPTD_RHSFUNC_ERR -10
#define CV_UNREC_RHSFUNC_ERR -11
#define CV_RTFUNC_FAIL       -12
#define CV_MEM_FAIL          -20
#define CV_MEM_NULL          -21
#define CV_ILL_INPUT         -22
#define CV_TOO_CLOSE         -27

typedef int (*CVRhsFn)(sunrealtype t, N_Vector y, N_Vector ydot, void* user_data);
typedef int (*CVRootFn)(sunrealtype t, N_Vector y, sunrealtype* gout,
                        void* user_data);

void* CVodeCreate(int lmm, SUNContext sunctx);
int   CVodeInit(void* cvode_mem, CVRhsFn f, sunrealtype t0, N_Vector y0);
int   CVodeReInit(void* cvode_mem, sunrealtype t0, N_Vector y0);
int   CVodeSStolerances(void* cvode_mem, sunrealtype reltol, sunrealtype abstol);
int   CVodeSVtolerances(void* cvode_mem, sunrealtype reltol, N_Vector abstol);
int   CVodeSetUserData(void* cvode_mem, void* user_data);
int   CVodeSetMaxNumSteps(void* cvode_mem, long int mxsteps);
int   CVodeSetMaxStep(void* cvode_mem, sunrealtype hmax);
int   CVodeSetMinStep(void* cvode_mem, sunrealtype hmin);
int   CVodeSetInitStep(void* cvode_mem, sunrealtype hin);
int   CVodeSetStopTime(void* cvode_mem, sunrealtype tstop);
int   CVodeClearStopTime(void* cvode_mem);
int   CVodeRootInit(void* cvode_mem, int nrtfn, CVRootFn g);
int   CVodeSetRootDirection(void* cvode_mem, int* rootdir);
int   CVodeSetNoInactiveRootWarn(void* cvode_mem);
int   CVode(void* cvode_mem, sunrealtype tout, N_Vector yout, sunrealtype* tret,
            int itask);
int   CVodeGetRootInfo(void* cvode_mem, int* rootsfound);
int   CVodeGetNumSteps(void* cvode_mem, long int* nsteps);
int   CVodeGetNumRhsEvals(void* cvode_mem, long int* nfevals);
int   CVodeGetNumGEvals(void* cvode_mem, long int* ngevals);
char* CVodeGetReturnFlagName(long int flag); /* malloc'ed: caller frees */
void  CVodeFree(void** cvode_mem);

/* ---- sundials/sundials_nonlinearsolver.h, sunnonlinsol_fixedpoint.h ----- */
typedef struct _generic_SUNNonlinearSolver* SUNNonlinearSolver;
SUNNonlinearSolver SUNNonlinSol_FixedPoint(N_Vector y, int m, SUNContext sunctx);
SUNErrCode         SUNNonlinSolFree(SUNNonlinearSolver NLS);
int CVodeSetNonlinearSolver(void* cvode_mem, SUNNonlinearSolver NLS);

/* ---- cvode/cvode_ls.h (v7) ----------------------------------------------- */
typedef int (*CVLsJacFn)(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix Jac,
                         void* user_data, N_Vector tmp1, N_Vector tmp2,
                         N_Vector tmp3);
int CVodeSetLinearSolver(void* cvode_mem, SUNLinearSolver LS, SUNMatrix A);
int CVodeSetJacFn(void* cvode_mem, CVLsJacFn jac);
int CVodeGetNumJacEvals(void* cvode_mem, long int* njevals);

/* ---- ida/ida.h (v7) ------------------------------------------------------ */
#define IDA_NORMAL   1
#define IDA_ONE_STEP 2

#define IDA_YA_YDP_INIT 1
#define IDA_Y_INIT      2

#define IDA_SUCCESS      0
#define IDA_TSTOP_RETURN 1
#define IDA_ROOT_RETURN  2
#define IDA_WARNING     99

#define IDA_TOO_MUCH_WORK  -1
#define IDA_TOO_MUCH_ACC   -2
#define IDA_ERR_FAIL       -3
#define IDA_CONV_FAIL      -4
#define IDA_LINIT_FAIL     -5
#define IDA_LSETUP_FAIL    -6
#define IDA_LSOLVE_FAIL    -7
#define IDA_RES_FAIL       -8
#define IDA_REP_RES_ERR    -9
#define IDA_RTFUNC_FAIL    -10
#define IDA_CONSTR_FAIL    -11
#define IDA_FIRST_RES_FAIL -12
#define IDA_LINESEARCH_FAIL -13
#define IDA_NO_RECOVERY    -14
#define IDA_ILL_INPUT      -22

typedef int (*IDAResFn)(sunrealtype tt, N_Vector yy, N_Vector yp, N_Vector rr,
                        void* user_data);
typedef int (*IDARootFn)(sunrealtype t, N_Vector y, N_Vector yp,
                         sunrealtype* gout, void* user_data);

void* IDACreate(SUNContext sunctx);
int   IDAInit(void* ida_mem, IDAResFn res, sunrealtype t0, N_Vector yy0,
              N_Vector yp0);
int   IDAReInit(void* ida_mem, sunrealtype t0, N_Vector yy0, N_Vector yp0);
int   IDASStolerances(void* ida_mem, sunrealtype reltol, sunrealtype abstol);
int   IDASVtolerances(void* ida_mem, sunrealtype reltol, N_Vector abstol);
int   IDACalcIC(void* ida_mem, int icopt, sunrealtype tout1);
int   IDASetUserData(void* ida_mem, void* user_data);
int   IDASetMaxNumSteps(void* ida_mem, long int mxsteps);
int   IDASetInitStep(void* ida_mem, sunrealtype hin);
int   IDASetMaxStep(void* ida_mem, sunrealtype hmax);
int   IDASetMinStep(void* ida_mem, sunrealtype hmin);
int   IDASetStopTime(void* ida_mem, sunrealtype tstop);
int   IDAClearStopTime(void* ida_mem);
int   IDASetId(void* ida_mem, N_Vector id);
int   IDASetSuppressAlg(void* ida_mem, sunbooleantype suppressalg);
int   IDARootInit(void* ida_mem, int nrtfn, IDARootFn g);
int   IDASetRootDirection(void* ida_mem, int* rootdir);
int   IDASetNoInactiveRootWarn(void* ida_mem);
int   IDASolve(void* ida_mem, sunrealtype tout, sunrealtype* tret, N_Vector yret,
               N_Vector ypret, int itask);
int   IDAGetConsistentIC(void* ida_mem, N_Vector yy0_mod, N_Vector yp0_mod);
int   IDAGetRootInfo(void* ida_mem, int* rootsfound);
int   IDAGetNumSteps(void* ida_mem, long int* nsteps);
int   IDAGetNumResEvals(void* ida_mem, long int* nrevals);
int   IDAGetNumGEvals(void* ida_mem, long int* ngevals);
char* IDAGetReturnFlagName(long int flag);   /* malloc'ed: caller frees */
void  IDAFree(void** ida_mem);

/* ---- ida/ida_ls.h (v7) --------------------------------------------------- */
typedef int (*IDALsJacFn)(sunrealtype t, sunrealtype c_j, N_Vector y,
                          N_Vector yp, N_Vector r, SUNMatrix Jac,
                          void* user_data, N_Vector tmp1, N_Vector tmp2,
                          N_Vector tmp3);
int IDASetLinearSolver(void* ida_mem, SUNLinearSolver LS, SUNMatrix A);
int IDASetJacFn(void* ida_mem, IDALsJacFn jac);
int IDAGetNumJacEvals(void* ida_mem, long int* njevals);

#ifdef __cplusplus
}
#endif

#endif /* GS_SUNDIALS7_H */
